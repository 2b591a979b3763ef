"""Observability regions (paper 002, Algorithm 3.1): region structure, an oracle, pair sets, executors, files.

The paper's figure features (Figs. 3-6) are in ``tests/studies/test_paper002_powertrain.py``; the
``hybobs regions`` command in ``tests/app/test_cli_regions.py``.
"""

import itertools
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from canonical import slab_pwa
from exact_oracle import linprog_free

from hybobs_opt.errors import ModelError
from hybobs_opt.executor import DaskExecutor, ProcessExecutor, SerialExecutor
from hybobs_opt.regions import analyse_observability, enumerate_modes, load_analysis, save_analysis
from hybobs_opt.studies.paper002_powertrain.systems import powertrain3


@pytest.fixture(scope="module")
def pt3_T3():
    return analyse_observability(powertrain3(), 3)


def test_region_structure_T3(pt3_T3):
    s = pt3_T3.summary()
    # 3 modes, but the twist angle moves at most Ts*|tau*omega_m - omega_l| <= 0.1 rad per step:
    # the shaft cannot jump from negative to positive contact in one step, so fewer than 3^3 regions.
    assert 0 < s["n_regions"] < 27
    assert s["n_lps_avoided_by_pruning"] > 0
    # The all-backlash sequence is a region and is rank deficient (eq. 18: omega_m decoupled).
    seqs = [r.sequence for r in pt3_T3.regions]
    assert (1, 1, 1) in seqs
    assert not pt3_T3.full_rank[seqs.index((1, 1, 1))]
    # All-contact sequences determine the state from three engine speeds.
    assert pt3_T3.full_rank[seqs.index((2, 2, 2))] and pt3_T3.full_rank[seqs.index((0, 0, 0))]


def test_output_maps_match_simulation(pt3_T3):
    """Eq. (4): Y = C_i x + D_i U + f_i on P_i, checked against the simulator at interior points."""
    from hybobs_opt.sim import simulate_pwa_batch

    plant = pt3_T3.system
    checked = 0
    for reg in pt3_T3.regions:
        # a point of P_i: the Chebyshev centre
        from hybobs_opt.systems import Polytope as P

        centre, radius = P(reg.H, reg.h).chebyshev_ball(pt3_T3.enumeration.scale)
        assert radius > 0
        x, U = centre[:3], centre[3:]
        X, Q, Y = simulate_pwa_batch(plant, x[None], U.reshape(1, 3, 1))
        assert tuple(Q[0]) == reg.sequence
        np.testing.assert_allclose(Y[0, :, 0], reg.C @ x + reg.D @ U + reg.f, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(X[0, 3], reg.Phi @ x + reg.Gamma @ U + reg.phi, rtol=1e-10, atol=1e-9)
        checked += 1
    assert checked == len(pt3_T3.regions)


# ------------------------------------------------------------------ oracle
def _oracle_maps(system, seq, T):
    """(x, U) -> constraints and outputs of a mode sequence, composed directly (independent of enumeration)."""
    n, m = system.n, system.m
    Phi, Gam, phi = np.eye(n), np.zeros((n, T * m)), np.zeros(n)
    rows, rhs, Cs, Ds, fs = [], [], [], [], []
    dom = system.domain
    for k, i in enumerate(seq):
        mode = system.modes[i]
        Sel = np.zeros((m, T * m))
        Sel[:, k * m:(k + 1) * m] = np.eye(m)
        for poly in (mode.guard, dom):
            Ax, Au = poly.A[:, :n], poly.A[:, n:]
            rows.append(np.hstack([Ax @ Phi, Ax @ Gam + Au @ Sel]))
            rhs.append(poly.b - Ax @ phi)
        Cs.append(mode.C @ Phi)
        Ds.append(mode.C @ Gam + mode.D @ Sel)
        fs.append(mode.C @ phi + mode.c)
        Phi, Gam, phi = mode.A @ Phi, mode.A @ Gam + mode.B @ Sel, mode.A @ phi + mode.a
    return np.vstack(rows), np.concatenate(rhs), np.vstack(Cs), np.vstack(Ds), np.concatenate(fs)


def _max_slack_highs(A_ub, b_ub, A_eq=None, b_eq=None):
    norms = np.linalg.norm(A_ub, axis=1)
    keep = norms > 1e-12
    if np.any(b_ub[~keep] < 0):  # a row that no longer depends on the variables and is violated
        return -np.inf
    A = np.hstack([A_ub[keep], norms[keep, None]])
    c = np.zeros(A.shape[1])
    c[-1] = -1
    Aeq = None if A_eq is None else np.hstack([A_eq, np.zeros((A_eq.shape[0], 1))])
    res = linprog(c, A_ub=A, b_ub=b_ub[keep], A_eq=Aeq, b_eq=b_eq, bounds=[(None, None)] * (A.shape[1] - 1) + [(None, 1.0)], method="highs")
    return -res.fun if res.status == 0 else -np.inf


def oracle_classify(system, T, x, tol=1e-6):
    """Definition 2.2 by brute force: every mode sequence and every pair of sequences, HiGHS LPs."""
    n = system.n
    seqs = list(itertools.product(range(system.n_modes), repeat=T))
    maps = {s: _oracle_maps(system, s, T) for s in seqs}
    inside = []
    for s, (H, h, C, D, f) in maps.items():
        if _max_slack_highs(H[:, n:], h - H[:, :n] @ x) > tol:
            inside.append(s)
    if not inside:
        return "infeasible"
    for s in inside:
        if np.linalg.matrix_rank(maps[s][2], tol=1e-9) < n:
            return "unobservable"
        H, h, C, D, f = maps[s]
        for s2 in seqs:
            if s2 == s:
                continue
            H2, h2, C2, D2, f2 = maps[s2]
            # variables (x^, U): (x, U) in P_s, (x^, U) in P_s2, C x + D U + f = C2 x^ + D2 U + f2
            A_ub = np.vstack([np.hstack([np.zeros((H.shape[0], n)), H[:, n:]]), H2])
            b_ub = np.concatenate([h - H[:, :n] @ x, h2])
            A_eq = np.hstack([-C2, D - D2])
            b_eq = f2 - f - C @ x
            if _max_slack_highs(A_ub, b_ub, A_eq, b_eq) > tol:
                return "unobservable"
    return "observable"


@settings(max_examples=10, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), n=st.integers(2, 3), n_modes=st.integers(2, 3), T=st.integers(2, 4))
def test_point_query_agrees_with_brute_force_oracle(seed, n, n_modes, T):
    T = max(T, n)  # eq. (8): T p >= n with p = 1
    if n_modes ** T > 27:  # keep the brute-force oracle (all pairs of sequences) affordable
        T = 3
    system = slab_pwa(seed, n, n_modes)
    analysis = analyse_observability(system, T)
    rng = np.random.default_rng(seed)
    for x in rng.uniform(-1, 1, size=(5, n)):
        assert analysis.classify(x) == oracle_classify(system, T, x), f"x = {x}"


# ------------------------------------------------------------------ pair sets: closed, full, distinct
def brute_force_pair_pieces(system, T, seqs, full_rank, tol=1e-6, sep=1e-5):
    """The pieces ``(i, j)`` of B_T by brute force, written from their definition without the toolbox's LP code.

    Regions are rebuilt from the mode sequences (:func:`_oracle_maps`); each closed ``R_ij``
    (``i`` in ``I``, any ``j != i``) is written on the nullspace of its output equalities
    (``scipy.linalg.null_space``) and decided with HiGHS: non-empty, a full-dimensional
    projection on ``x`` (its affine hull grown from support points, one direction orthogonal to
    the current hull at a time: the hull is full when ``n`` directions each move ``x`` by more
    than ``tol``), and a point with ``|x - x^| > sep`` (scaled).
    """
    from scipy.linalg import lstsq, null_space

    n = system.n
    half, mid = system.scales()
    sw = np.concatenate([half[:n], half[:n], np.tile(half[n:], T)])
    cw = np.concatenate([mid[:n], mid[:n], np.tile(mid[n:], T)])
    maps = [_oracle_maps(system, s, T) for s in seqs]
    out = set()
    for i, (Hi, hi, Ci, Di, fi) in enumerate(maps):
        if not full_rank[i]:
            continue
        for j, (Hj, hj, Cj, Dj, fj) in enumerate(maps):
            if j == i:
                continue
            G = np.vstack([np.hstack([Hi[:, :n], np.zeros((Hi.shape[0], n)), Hi[:, n:]]),
                           np.hstack([np.zeros((Hj.shape[0], n)), Hj])])
            g = np.concatenate([hi, hj])
            E, e = np.hstack([Ci, -Cj, Di - Dj]), fj - fi
            Gs, gs = G * sw, g - G @ cw
            nr = np.linalg.norm(Gs, axis=1)
            Gs, gs = Gs / nr[:, None], gs / nr + 1e-9
            Es, es = E * sw, e - E @ cw
            Nn = null_space(Es, rcond=1e-12)
            w0 = lstsq(Es, es)[0]
            if np.linalg.norm(Es @ w0 - es) > 1e-7 * (1 + np.linalg.norm(es)):
                continue
            Gn, gn = Gs @ Nn, gs - Gs @ w0

            def opt(c):
                cn = c @ Nn
                if np.linalg.norm(cn) <= 1e-12 * (1 + np.linalg.norm(c)):  # constant on the set
                    cn = np.zeros_like(cn)
                for method in ("highs-ds", "highs-ipm", "highs"):  # HiGHS's methods fail on different degenerate LPs
                    r = linprog_free(cn, Gn, gn, method)  # scipy's linprog, without its per-call overhead
                    if r.status in (0, 2):
                        break
                assert r.status in (0, 2), r.message
                return (w0 + Nn @ r.x) if r.status == 0 else None

            p0 = opt(np.zeros(Gs.shape[1]))
            if p0 is None:
                continue
            pts, full = [p0[:n]], True
            for k in range(n):
                if k:
                    _, sv, Vt = np.linalg.svd(np.array(pts[1:]) - pts[0])
                    cdir = Vt[k]
                else:
                    cdir = np.eye(n)[0]
                for sgn in (1.0, -1.0):
                    c = np.zeros(Gs.shape[1])
                    c[:n] = -sgn * cdir
                    w = opt(c)
                    if w is not None and abs(cdir @ (w[:n] - pts[0])) > tol:  # None: HiGHS lost a sliver of a set
                        pts.append(w[:n])
                        break
                else:
                    full = False
                    break
            if not full:
                continue
            for d, sgn in itertools.product(range(n), (1.0, -1.0)):
                c = np.zeros(Gs.shape[1])
                c[d], c[n + d] = -sgn, sgn
                w = opt(c)
                if w is not None and sgn * (w[d] - w[n + d]) > sep:
                    out.add((i, j))
                    break
    return out


@pytest.mark.slow
@pytest.mark.parametrize("T, gear_ratio", [(3, 1 / 12), (4, 1 / 12), (4, 1.0), (5, 1 / 12)])
def test_pair_pieces_agree_with_brute_force(T, gear_ratio):
    """B_T's pair pieces are exactly the closed, full, two-state pair sets (model 16).

    Measured: 0 / 32 / 32 / 218 pieces at (3, 1/12), (4, 1/12), (4, 1), (5, 1/12), identical
    lists.  Before the fix the toolbox had 266 pieces at T = 5: 86 in which the outputs force
    x^ = x on a shared guard face (interior states were called unobservable), and it missed 38
    face-confined sets whose states are genuinely indistinguishable for an input sequence that
    steers the trajectory onto the guard (Definition 2.2 quantifies over every input).
    """
    system = powertrain3(gear_ratio=gear_ratio)
    analysis = analyse_observability(system, T)
    ref = brute_force_pair_pieces(system, T, [r.sequence for r in analysis.regions], analysis.full_rank)
    assert {(p.i, p.j) for p in analysis.pairs} == ref
    assert set(analysis.stats["pairs_dropped_same_state"]).isdisjoint(ref)


def test_pairs_forcing_the_same_state_are_left_out_and_counted():
    """Model 16, T = 5: the pair sets whose outputs force x^ = x are reported, not kept in B_T."""
    analysis = analyse_observability(powertrain3(), 5)
    same = analysis.stats["pairs_dropped_same_state"]
    assert analysis.summary()["n_pairs_dropped_same_state"] == len(same) > 0
    n = 3
    half, _ = powertrain3().scales()
    for i, j in same[:: max(1, len(same) // 10)]:
        ri, rj = analysis.regions[i], analysis.regions[j]
        # independent check: on every point of the closed R_ij (HiGHS, explicit equalities) x = x^
        A_ub, b_ub, A_eq, b_eq = _pair_lps_scaled(powertrain3(), 5, ri, rj)
        for d, sgn in itertools.product(range(n), (1.0, -1.0)):
            c = np.zeros(A_ub.shape[1])
            c[d], c[n + d] = -sgn, sgn
            res = linprog(c, A_ub=A_ub, b_ub=b_ub + 1e-9, A_eq=A_eq, b_eq=b_eq, bounds=(None, None), method="highs")
            assert res.status == 2 or -res.fun <= 1e-5, (i, j, d, -res.fun)


@pytest.mark.slow
def test_reduced_pairs_all_dimensions_returns_every_nonempty_pair():
    """Model 16, T = 3: every closed R_ij with i in I and j not in I (48, counted here with HiGHS)."""
    analysis = analyse_observability(powertrain3(), 3)
    expected = set()
    for i in analysis.index_set:
        for j in analysis.rank_deficient:
            A_ub, b_ub, A_eq, b_eq = _pair_lps_scaled(powertrain3(), 3, analysis.regions[i], analysis.regions[j])
            res = linprog(np.zeros(A_ub.shape[1]), A_ub=A_ub, b_ub=b_ub + 1e-9, A_eq=A_eq, b_eq=b_eq,
                          bounds=(None, None), method="highs")
            if res.status == 0:
                expected.add((i, j))
    assert len(expected) == 48
    assert {(p.i, p.j) for p in analysis.reduced_pairs_all_dimensions()} == expected


def test_nan_solver_answers_are_never_certified(monkeypatch):
    """A DAQP answer with a NaN point and a success flag (CasADi's bundled copy is known to give
    them) is not taken: the analysis of model 16 at T = 3 is unchanged (16 regions, 12 pieces)."""
    import daqp

    from hybobs_opt.geometry import lp

    real = daqp.solve

    def nan_solve(*args, **kwargs):
        x, fval, flag, info = real(*args, **kwargs)
        return np.full_like(x, np.nan), fval, 1, info

    monkeypatch.setattr(lp.daqp, "solve", nan_solve)
    analysis = analyse_observability(powertrain3(), 3)
    assert len(analysis.regions) == 16
    assert analysis.n_unobservable_pieces == 12


def test_solve_lp_checks_the_returned_point(monkeypatch):
    """An "optimal" point that violates the constraints (moved by 1e-3) or is NaN is a SolverError."""
    from hybobs_opt.geometry import lp
    from hybobs_opt.errors import SolverError
    from hybobs_opt.status import Status

    good = lp.solve_lp(np.array([1.0, 1.0]), -np.eye(2), np.zeros(2), problem="toy")
    assert good.optimal and np.allclose(good.x, 0.0)
    for bad in (np.array([-1e-3, 0.0]), np.array([np.nan, 0.0])):
        monkeypatch.setattr(lp, "_call_highs", lambda *a, _x=bad: lp._HighsAnswer(Status.OPTIMAL, "ok", _x, 0.0))
        with pytest.raises(SolverError, match="toy"):
            lp.solve_lp(np.array([1.0, 1.0]), -np.eye(2), np.zeros(2), problem="toy")


# ------------------------------------------------------------------ thin pair sets
def _pair_lps_scaled(system, T, ri, rj):
    """R_ij over w = (x, x^, U) scaled to [-1, 1] by the bounds: A_ub w <= b_ub, A_eq w = b_eq (built here)."""
    n = system.n
    half, mid = system.scales()
    scale = np.concatenate([half[:n], half[:n], np.tile(half[n:], T)])
    centre = np.concatenate([mid[:n], mid[:n], np.tile(mid[n:], T)])
    G = np.vstack([np.hstack([ri.H[:, :n], np.zeros((ri.H.shape[0], n)), ri.H[:, n:]]),
                   np.hstack([np.zeros((rj.H.shape[0], n)), rj.H])])
    g = np.concatenate([ri.h, rj.h])
    E = np.hstack([ri.C, -rj.C, ri.D - rj.D])
    e = rj.f - ri.f
    return G * scale, g - G @ centre, E * scale, e - E @ centre


def test_pair_sets_whose_outputs_pin_x_minus_xhat_are_left_out_of_B_T():
    """The 11-piece PWA piston at T = 3: pair sets with a fat ball inside their equality subspace
    whose outputs pin ``x - x^`` down (an equality of singular value ~1e-7 of the largest) are
    dropped, none is a piece.  They are dropped as same-state pairs: appending the rows
    ``x - x^`` to the equalities leaves their rank unchanged, decided here from LAPACK's
    singular values (a gap of 1e3 or more on each side of the rank threshold), independently of the
    package's SVD; where such a set is non-empty, its projection on x is also thinner than the
    tolerance along the pinned direction (HiGHS on the explicit equalities).  (A criterion on
    ``|N_x - N_x^|`` instead called 24 of them thin: that value is ``eps / 1e-7`` in LAPACK's
    nullspace basis and crosses the threshold with the basis.)"""
    from scipy.linalg import null_space

    from hybobs_opt.studies.paper004_nonmonotonic.piston_pwa import magnetic_piston_pwa
    from hybobs_opt.tolerances import RANK_RTOL, REGION_SLACK_TOL

    system = magnetic_piston_pwa(11)
    T = 3
    analysis = analyse_observability(system, T)
    same = analysis.stats["pairs_dropped_same_state"]
    assert len(same) == analysis.summary()["n_pairs_dropped_same_state"] > 0
    kept = {(p.i, p.j) for p in analysis.pairs}
    assert not kept & set(same)
    n = system.n
    pinned_non_empty = 0
    for i, j in same:
        A_ub, b_ub, A_eq, b_eq = _pair_lps_scaled(system, T, analysis.regions[i], analysis.regions[j])
        J = np.hstack([np.eye(n), -np.eye(n), np.zeros((n, A_eq.shape[1] - 2 * n))])
        s_E = np.linalg.svd(A_eq, compute_uv=False)
        s_EJ = np.linalg.svd(np.vstack([A_eq, J]), compute_uv=False)
        r = int(np.sum(s_E > RANK_RTOL * s_E[0]))
        assert r < s_EJ.size and s_EJ[r] <= 1e-3 * RANK_RTOL * s_EJ[0], (i, j, s_EJ)  # x - x^ in the row space
        assert s_E[r - 1] >= 1e3 * RANK_RTOL * s_E[0]  # the rank itself is clear
        if s_E[r - 1] > 1e-4 * s_E[0]:
            continue  # a well-conditioned pin: not the case this test is about
        N = null_space(A_eq)
        u = np.linalg.svd(N[:n])[0][:, -1]
        c = np.concatenate([u, np.zeros(A_ub.shape[1] - n)])
        free = [(None, None)] * A_ub.shape[1]
        hi = linprog(-c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=free, method="highs")
        lo = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=free, method="highs")
        if hi.status != 0 or lo.status != 0:
            continue  # empty: same-state pairs are reported without an emptiness test
        width = -hi.fun - lo.fun
        assert width <= 2 * REGION_SLACK_TOL + 1e-7, (i, j, width)
        # ... although the Chebyshev radius inside the equality subspace is far above the tolerance,
        # which is all the slack test alone looks at.
        w0 = np.linalg.lstsq(A_eq, b_eq, rcond=None)[0]
        unit = 1.0 / np.linalg.norm(A_ub, axis=1)
        Gv, gv = (A_ub * unit[:, None]) @ N, (b_ub - A_ub @ w0) * unit
        constant = np.linalg.norm(Gv, axis=1) <= 1e-10  # rows that do not vary on the subspace
        assert np.all(gv[constant] >= -1e-10)
        assert _max_slack_highs(Gv[~constant], gv[~constant]) > 100 * REGION_SLACK_TOL
        pinned_non_empty += 1
    assert pinned_non_empty >= 4
    # The pair sets that carry the observer's data (eq. 15, all dimensions) are not filtered.
    assert len(analysis.reduced_pairs_all_dimensions()) >= len(analysis.reduced_pairs)


# ------------------------------------------------------------------ executors, files, bad input
def _pair_keys(a):
    return [(p.i, p.j) for p in a.pairs]


@pytest.fixture
def always_parallel(monkeypatch):
    """Send even a small problem to the executor (by default small ones stay in-process)."""
    from hybobs_opt.regions import enumeration, observability

    monkeypatch.setattr(enumeration, "PARALLEL_MIN_SEQUENCES", 0)
    monkeypatch.setattr(observability, "PARALLEL_MIN_PAIRS", 0)


def test_small_problems_stay_in_process():
    ex = ProcessExecutor(2)
    try:
        a = analyse_observability(powertrain3(), 3, executor=ex)
    finally:
        ex.close()
    assert a.stats["executor"] == "serial" and a.enumeration.stats["executor"] == "serial"


def test_executors_give_identical_results(always_parallel):
    plant = powertrain3()
    serial = analyse_observability(plant, 5, executor=SerialExecutor())
    ex = ProcessExecutor(2)
    try:
        procs = analyse_observability(plant, 5, executor=ex)
    finally:
        ex.close()
    assert procs.stats["executor"] == "processes" and procs.enumeration.stats["executor"] == "processes"
    assert [r.sequence for r in serial.regions] == [r.sequence for r in procs.regions]
    assert _pair_keys(serial) == _pair_keys(procs)


@pytest.mark.distributed
@pytest.mark.slow
def test_dask_local_cluster_gives_identical_results(always_parallel):
    plant = powertrain3()
    serial = analyse_observability(plant, 5)
    ex = DaskExecutor(local_workers=2)
    try:
        dask = analyse_observability(plant, 5, executor=ex)
    finally:
        ex.close()
    assert dask.stats["executor"] == "dask" and dask.enumeration.stats["executor"] == "dask"
    assert [r.sequence for r in serial.regions] == [r.sequence for r in dask.regions]
    assert _pair_keys(serial) == _pair_keys(dask)
    # the grouped pair tests on the cluster (data scattered once, DaskExecutor.map_shared)
    assert serial.stats["pairs_ruled_out_by_group"] == dask.stats["pairs_ruled_out_by_group"]
    assert serial.stats["n_pairs_ruled_out_by_group"] > 0 and serial.n_pair_lps == dask.n_pair_lps


def test_save_load_roundtrip(tmp_path, pt3_T3):
    path = save_analysis(pt3_T3, tmp_path / "r.json", "powertrain3", {})
    loaded = load_analysis(path)
    assert _pair_keys(loaded) == _pair_keys(pt3_T3) and loaded.full_rank == pt3_T3.full_rank
    for x in ([0.0, 100.0, 25.0], [0.12, 100.0, 8.0], [-0.1, 300.0, 25.0]):
        assert loaded.classify(x) == pt3_T3.classify(x)
    data = json.loads(path.read_text())
    data["version"] = 99
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(ModelError, match="version"):
        load_analysis(tmp_path / "bad.json")


def test_horizon_below_necessary_condition_is_an_error():
    with pytest.raises(ModelError, match=r"eq\. 8"):
        enumerate_modes(powertrain3(), 2)
    with pytest.raises(ModelError, match="positive integer"):
        enumerate_modes(powertrain3(), 0)


def test_cut_sets_union_difference_agrees_with_point_queries(pt3_T3):
    """O_T = X*_T minus B_T (eq. 9) as polygons on the cut omega_l = 25 matches the exact point query."""
    X, B, O = pt3_T3.cut_sets({"omega_l": 25.0})
    assert len(X) > 0 and len(B) > 0 and len(O) > 0
    rng = np.random.default_rng(7)
    pts = np.column_stack([rng.uniform(-0.2, 0.2, 150), rng.uniform(0.0, 600.0, 150)])
    labels = np.array([pt3_T3.classify([p[0], p[1], 25.0]) for p in pts])
    np.testing.assert_array_equal(O.contains(pts), labels == "observable")
    np.testing.assert_array_equal(X.contains(pts), labels != "infeasible")
    # the band |theta| < alpha is in B_T, never in O_T (Fig. 3b)
    band = np.column_stack([np.full(20, 0.0), np.linspace(10.0, 590.0, 20)])
    assert not O.contains(band).any() and B.contains(band).all()


def test_plot_cut_labels_axes_with_units_and_factors(tmp_path, monkeypatch):
    """``plot_cut(units=...)`` labels ``"name [unit]"``; a display factor reads ``"10 theta [rad]"``."""
    import matplotlib.figure

    from hybobs_opt.regions import analyse_observability, compute_cut, plot_cut
    from hybobs_opt.studies import get_example

    labels = []
    real = matplotlib.figure.Figure.savefig

    def spy(self, *a, **kw):
        labels.append((self.axes[0].get_xlabel(), self.axes[0].get_ylabel()))
        return real(self, *a, **kw)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    cut = compute_cut(analyse_observability(get_example("powertrain3").build(), 3), {"omega_l": 25.0}, (5, 4))
    units = {"theta": "rad", "omega_m": "rad/s"}
    plot_cut(cut, tmp_path / "a.png", units=units)
    plot_cut(cut, tmp_path / "b.png", units=units, stretch={"theta": 10.0})
    plot_cut(cut, tmp_path / "c.png")
    assert labels == [("theta [rad]", "omega_m [rad/s]"), ("10 theta [rad]", "omega_m [rad/s]"), ("theta", "omega_m")]
