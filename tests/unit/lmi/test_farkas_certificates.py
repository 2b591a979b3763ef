"""Issue 16: an ``InfeasibleError`` always carries a certificate that verifies, otherwise it is a
``SolverError``.

The Farkas certificate (:mod:`hybobs_opt.lmi.farkas`) is checked here against problems whose
infeasibility is known by hand (an unobservable unstable mode: no gain can help), against
feasible problems (no certificate), against a tampered ray (the re-check fails), and in the
designs that used to raise ``InfeasibleError`` without one: the continuous observer of paper 000
(``design_continuous_observer``) and the residual generators (``design_residual_bank``).  A
solver that wrongly answers "infeasible" for a feasible design must give a ``SolverError``.
"""

from __future__ import annotations

from dataclasses import replace

import cvxpy as cp
import numpy as np
import pytest

from hybobs_opt.errors import InfeasibleError, SolverError
from hybobs_opt.geometry import Polytope
from hybobs_opt.lmi.farkas import conic_certificate
from hybobs_opt.synthesis.continuous_design import design_continuous_observer
from hybobs_opt.synthesis.location_design import design_residual_bank
from hybobs_opt.status import Status
from hybobs_opt.systems.hybrid import HybridAutomaton, Location


def observer_lmi(A, C, alpha, gain_bound=None):
    """``P >= I``, ``sym(A'P - C'Y') + 2 alpha P <= -I`` (and ``||Y|| <= gain_bound``), built here."""
    n, p = A.shape[0], C.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((n, p))
    S = A.T @ P + P @ A - C.T @ Y.T - Y @ C + 2 * alpha * P
    cons = [P >> np.eye(n), 0.5 * (S + S.T) << -np.eye(n)]
    if gain_bound is not None:
        cons.append(cp.norm(Y, 2) <= gain_bound)
    return cp.Problem(cp.Minimize(0), cons)


def test_unobservable_unstable_mode_is_certified_for_every_gain():
    # x1' = 0.5 x1 is not seen by y = x2: no gain makes the error decay (PBH)
    A = np.array([[0.5, 0.0], [0.0, -1.0]])
    C = np.array([[0.0, 1.0]])
    cert = conic_certificate(observer_lmi(A, C, 0.0), "toy")
    assert cert is not None and cert.verify()
    r = cert.residuals()
    assert r["gap"] < -1e-3 and r["stationarity"] < 1e-7 and r["cone"] < 1e-7
    # the same with a gain bound (a second-order cone in the conic form)
    cert = conic_certificate(observer_lmi(A, C, 0.0, gain_bound=5.0), "toy, bounded gain")
    assert cert is not None and cert.verify() and cert.cones["soc"]


def test_feasible_problem_has_no_certificate_and_a_tampered_ray_fails():
    A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    C = np.array([[1.0, 0.0]])
    assert conic_certificate(observer_lmi(A, C, 0.5), "feasible") is None
    bad = conic_certificate(observer_lmi(np.array([[0.5, 0.0], [0.0, -1.0]]), np.array([[0.0, 1.0]]), 0.0), "toy")
    y = bad.y.copy()
    y[np.argmax(np.abs(y))] *= -1.0  # flips a sign: A'y = 0 or the cone fails
    assert not replace(bad, y=y).verify()
    assert not replace(bad, y=np.full_like(y, np.nan)).verify()


def one_location_automaton(A, C, name="toy") -> HybridAutomaton:
    names = tuple(f"x{i}" for i in range(A.shape[0]))
    loc = Location("q0", Polytope.from_box([-10.0] * A.shape[0], [10.0] * A.shape[0], names), A=A, B=np.zeros((A.shape[0], 1)),
                   C=C)
    return HybridAutomaton((loc,), Polytope.from_box([-10.0] * A.shape[0], [10.0] * A.shape[0], names), None,
                           Polytope.from_box([-1.0], [1.0], ("u",)), names, ("u",), ("y",), name)


def test_continuous_observer_infeasible_with_a_verified_certificate():
    # a lightly damped oscillator seen through its position: decay 50 1/s with ||G|| <= 1 is out of reach
    A = np.array([[0.0, 1.0], [-4.0, -0.1]])
    aut = one_location_automaton(A, np.array([[1.0, 0.0]]))
    with pytest.raises(InfeasibleError) as info:
        design_continuous_observer(aut, 50.0, gain_bound=1.0)
    cert = info.value.certificate
    assert cert is not None and cert.verify()


def test_residual_generator_infeasible_with_a_verified_certificate():
    """The decay-rate LMI of a generator at the rate Delta needs, under a gain bound (was an
    InfeasibleError without a certificate)."""
    from hybobs_opt.lmi.farkas import FarkasCertificate

    A = np.array([[0.0, 1.0], [-4.0, -0.1]])
    aut = one_location_automaton(A, np.array([[1.0, 0.0]]))
    with pytest.raises(InfeasibleError, match="decay-rate LMI is infeasible") as info:
        design_residual_bank(aut, 0.5, 1e-3, 1.0, gain_bound=2.0)
    cert = info.value.certificate
    assert isinstance(cert, FarkasCertificate) and cert.verify()
    # the bound is what fails: without it the same Delta is met
    assert design_residual_bank(aut, 0.5, 1e-3, 1.0).generators[0].decay > 0


def test_wrong_infeasible_answer_is_a_solver_error(monkeypatch):
    """A solver claiming "infeasible" for a feasible design: no certificate verifies, so no InfeasibleError."""
    import hybobs_opt.synthesis.continuous_design as ho
    from hybobs_opt.lmi.solve import SolveOutcome

    A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    aut = one_location_automaton(A, np.array([[1.0, 0.0]]))
    assert design_continuous_observer(aut, 1.0).decay >= 1.0 * (1 - 1e-6)  # feasible for real

    def lying(problem, **kwargs):
        return SolveOutcome(Status.INFEASIBLE, 0.0, 0.0, 0.0, "injected")

    monkeypatch.setattr(ho, "solve_problem", lying)
    with pytest.raises(SolverError, match="certificate"):
        design_continuous_observer(aut, 1.0)
