"""The decay oracle of issue 35 (``tests/decay_oracle.py``) checked on cases whose answer is known by hand.

* a scalar system with a nonlinearity and a nonlinear sensor, ``x' = a x + sin(x)/2``,
  ``y = 2 tanh(x/2)`` on ``x in [0.3, 1.2]``: the closed loop is ``a + theta - L mu`` with
  ``theta = cos(x)/2``, ``mu = 1 - tanh(x/2)^2`` (both decreasing there, so their ranges are the
  end-point values), hence ``sigma* = l mu_min - a - theta_max`` at ``L = l`` (grid path, 1 unknown);
* ``A = [[-5, 1], [0, 1]]``, ``y = x2``: ``A - L C = [[-5, 1 - l1], [0, 1 - l2]]`` is triangular
  for every gain, eigenvalues ``-5`` and ``1 - l2``, distinct, so the best quadratic rate with
  ``||L|| <= 3`` is ``min(5, 3 - 1) = 2`` at ``L = (0, 3)`` (grid path, 2 unknowns);
* ``A = [[a, b], [-b, a]]``, ``y = x`` (4 unknowns, random search + Nelder-Mead): every rate is at
  most ``-max Re eig(A - L) <= -tr(A - L) / 2 <= (2 l - 2 a) / 2`` (``|tr L| <= ||L||_* <= 2 l``),
  and ``L = l I`` attains ``l - a`` with ``P = I``: ``sigma* = l - a``;

and the oracle's parts on their own (interval arithmetic of the argument ranges, the numpy rate of a
``P``, the eigenvalue bound never below a certified rate).  No toolbox code beyond the public
system constructors is used.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import decay_oracle as D  # noqa: E402


def _system(A, C, *, f=None, h=None, lo, hi, names=None):
    from hybobs_opt.geometry.polytope import Polytope
    from hybobs_opt.systems.scalar_nonlinear import ScalarFunction, ScalarNonlinearSystem

    n = len(A)
    names = names or tuple(f"x{i + 1}" for i in range(n))
    kw = {}
    if f is not None:
        kw.update(F=[[1.0]] * n, E=[[1.0] + [0.0] * (n - 1)], f=(ScalarFunction.from_text(*f),))
    return ScalarNonlinearSystem(box=Polytope.from_box(lo, hi, names), A=A, C=C,
                                 h=None if h is None else (ScalarFunction.from_text(*h),), state_names=names, **kw)


def test_argument_ranges_are_the_extremes_over_the_box_corners():
    rng = np.random.default_rng(3)
    rows = rng.normal(size=(4, 3))
    lo, hi = np.array([-1.0, 0.5, -2.0]), np.array([2.0, 1.5, -1.0])
    corners = np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for c in (lo[2], hi[2])])
    vals = corners @ rows.T
    got = D.argument_ranges(rows, lo, hi)
    np.testing.assert_allclose(got[:, 0], vals.min(axis=0), rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(got[:, 1], vals.max(axis=0), rtol=1e-14, atol=1e-14)


def test_decay_of_a_lyapunov_matrix_is_the_generalised_eigenvalue():
    rng = np.random.default_rng(5)
    A = rng.normal(size=(3, 3)) - 3 * np.eye(3)
    P = np.eye(3) + 0.3 * (lambda M: M @ M.T)(rng.normal(size=(3, 3)))
    s = D.decay_of(P, A[None])
    M = A.T @ P + P @ A + 2 * s * P
    assert abs(np.linalg.eigvalsh(M).max()) < 1e-9 * np.linalg.norm(P)
    # a rate of P can never beat the spectral abscissa
    assert s <= -np.linalg.eigvals(A).real.max() + 1e-12


def test_scalar_nonlinear_case_known_answer():
    a, l, lo, hi = 0.4, 2.0, 0.3, 1.2
    sys_ = _system([[a]], [[1.0]], f=("sin/2", "sin(z)/2"), h=("2 tanh(z/2)", "2*tanh(z/2)"), lo=[-2.0], hi=[2.0])
    prob = D.problem_from_system(sys_)
    box = D.slope_box(prob, 0, lo, hi)
    theta = (0.5 * math.cos(hi), 0.5 * math.cos(lo))
    mu = (1 - math.tanh(hi / 2) ** 2, 1 - math.tanh(lo / 2) ** 2)
    np.testing.assert_allclose(box.f[0], theta, rtol=1e-12)
    np.testing.assert_allclose(box.h[0], mu, rtol=1e-12)
    np.testing.assert_allclose(box.f_args[0], (lo, hi), rtol=1e-15)
    As, Cs = D.vertex_matrices(prob, box)
    assert As.shape == (4, 1, 1)
    res = D.best_decay(As, Cs, l, grid=11, zooms=1, zoom_grid=5)
    expected = l * mu[0] - a - theta[1]
    assert res.sigma == pytest.approx(expected, rel=1e-9)
    assert res.L[0, 0] == pytest.approx(l)
    assert res.eig_bound_best == pytest.approx(expected, rel=1e-9)


def test_triangular_case_known_answer_grid():
    l = 3.0
    sys_ = _system([[-5.0, 1.0], [0.0, 1.0]], [[0.0, 1.0]], lo=[-1.0, -1.0], hi=[1.0, 1.0])
    prob = D.problem_from_system(sys_)
    As, Cs = D.vertex_matrices(prob, D.slope_box(prob, 0, -1.0, 1.0))
    assert As.shape == (1, 2, 2)  # a linear output adds no vertex
    res = D.best_decay(As, Cs, l, grid=13, zooms=1, zoom_grid=5)
    assert 2.0 * (1 - 3e-3) <= res.sigma <= 2.0 + 1e-9
    np.testing.assert_allclose(res.L, [[0.0], [3.0]], atol=0.1)  # the rate is within rtol of 2 only near (0, 3)
    assert res.eig_bound_best == pytest.approx(2.0, rel=1e-9)
    # the certified rate is proven by numpy for the returned pair
    assert D.decay_of(res.P, D.closed_loop(As, Cs, res.L)) >= res.sigma - 1e-12


def test_rotation_case_known_answer_random_search():
    a, b, l = 0.5, 2.0, 3.0
    sys_ = _system([[a, b], [-b, a]], [[1.0, 0.0], [0.0, 1.0]], lo=[-1.0, -1.0], hi=[1.0, 1.0])
    prob = D.problem_from_system(sys_)
    As, Cs = D.vertex_matrices(prob, D.slope_box(prob, 0, -1.0, 1.0))
    # without the alternating refinement: the random screening and the Nelder-Mead searches alone
    res = D.best_decay(As, Cs, l, random=1500, top=4, eig_starts=4, joint_maxfev=3000, start_rounds=1, rounds=3,
                       alternations=0)
    assert 0.97 * (l - a) <= res.sigma <= (l - a) + 1e-9
    assert np.linalg.norm(res.L, 2) <= l * (1 + 1e-12)
    assert res.eig_bound_best <= (l - a) + 1e-9


def test_eigenvalue_bound_is_never_below_the_certified_rate():
    rng = np.random.default_rng(11)
    As = np.array([[[0.0, 1.0], [1.0 + t, 0.0]] for t in (-0.5, 0.5)])
    Cs = np.array([[[m, 0.0]] for m in (0.6, 1.0)])
    As, Cs = np.concatenate([As, As]), np.concatenate([Cs, Cs[::-1]])
    for _ in range(3):
        L = rng.normal(size=(2, 1)) * 3 + np.array([[2.0], [4.0]])
        c = D.certified_decay(As, Cs, L)
        assert c.sigma <= c.upper + 1e-9
        assert D.decay_of(c.P, D.closed_loop(As, Cs, L)) == pytest.approx(c.sigma, abs=1e-12)


def test_recorded_rates_are_proven_by_their_recorded_pairs():
    """``tests/oracle_records/decay_oracle.json`` (``python -m tests.decay_oracle --record``): every recorded
    ``(P, L)`` still proves its rate, in numpy, on the slope box the oracle computes now for the same
    system, interval and bound (a changed system or oracle shows here), with ``||L||_2`` within the bound."""
    import json

    rec = json.loads(D.RECORD.read_text())
    systems = D._systems()
    cases = {c["id"]: c for c in D.CASES}
    assert set(cases) == {c["id"] for c in rec["cases"]}
    for r in rec["cases"]:
        case = cases[r["id"]]
        prob = D.problem_from_system(systems[case["system"]])
        box = D.slope_box(prob, case["coordinate"], case["lo"], case["hi"])
        np.testing.assert_allclose(box.f, np.array(r["slope_box"]["f"]).reshape(-1, 2), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(box.h, np.array(r["slope_box"]["h"]).reshape(-1, 2), rtol=1e-12, atol=1e-12)
        As, Cs = D.vertex_matrices(prob, box)
        L, P = np.array(r["L"]), np.array(r["P"])
        assert np.linalg.norm(L, 2) <= case["gain_bound"] * (1 + 1e-12)
        assert D.decay_of(P, D.closed_loop(As, Cs, L)) >= r["sigma"] - 1e-9 * abs(r["sigma"])
        assert r["sigma"] <= D.eig_bound(As, Cs, L) + 1e-9
        assert r["sigma_V"] == pytest.approx(2 * r["sigma"])
