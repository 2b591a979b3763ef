"""Issue 18, "The MHE formulated in CasADi": eq. (10) of paper 002 written once in CasADi SX.

1. The matrices every backend receives (DAQP's H / A / bounds / linear term, highspy's c / A /
   bounds, the CasADi plugins') equal the Jacobians and Hessians of the formulation's CasADi
   expressions, computed here with ``casadi.jacobian`` / ``casadi.hessian`` at random parameter
   values, for norms 2, 1 and inf on model (16) at T = 3.
2. A cost term, a parameter and an affine constraint added through the ``extend`` hook give the
   optimum of a brute-force oracle that shares no code with ``hybobs_opt.mhe``: every mode sequence
   of the window (3^3), each fixed-sequence convex QP by cvxpy + Clarabel with the dynamics written
   from the modes' A_i, B_i, a_i, C_i and guards.
3. ``certify_time_budget``: a tiny budget leaves noisy windows ``fallback`` (never ``observable``)
   with the reason.
"""

from __future__ import annotations

import itertools

import casadi as ca
import cvxpy as cp
import numpy as np
import pytest

import hybobs_opt.mhe.observer as observer_module
from hybobs_opt.errors import ModelError
from hybobs_opt.mhe import MHEObserver, MHESettings
from hybobs_opt.studies import get_example

T = 3
NOISE = 0.01


@pytest.fixture(scope="module")
def plant():
    return get_example("powertrain3").build()


@pytest.fixture(scope="module")
def noisy(plant):
    trace = get_example("powertrain3").scenario(plant)
    Y = trace.y + NOISE * np.random.default_rng(0).normal(size=trace.y.shape)
    return trace, Y


def _recording(monkeypatch):
    """Record what the observer hands its backend factory and every solve of the backend."""
    rec: dict = {}
    real_miqp, real_milp = observer_module.miqp_backend, observer_module.milp_backend

    def wrap(backend):
        real = backend.solve
        rec["solves"] = []

        def solve(f, lo, hi, centre=None, **kw):
            rec["solves"].append({"f": None if f is None else np.array(f), "lo": np.array(lo), "hi": np.array(hi),
                                  "centre": None if centre is None else np.array(centre)})
            return real(f, lo, hi, centre, **kw)

        backend.solve = solve
        return backend

    def miqp(solver, H, A, lb, ub, discrete, eq_rows, enc, options):
        rec.update(solver=solver, H=np.array(H), A=np.array(A), lb=np.array(lb), ub=np.array(ub),
                   discrete=np.array(discrete))
        return wrap(real_miqp(solver, H, A, lb, ub, discrete, eq_rows, enc, options))

    def milp(solver, c, A, lb, ub, discrete, options, **kw):
        rec.update(solver=solver, c=np.array(c), A=np.array(A), lb=np.array(lb), ub=np.array(ub),
                   discrete=np.array(discrete))
        return wrap(real_milp(solver, c, A, lb, ub, discrete, options, **kw))

    monkeypatch.setattr(observer_module, "miqp_backend", miqp)
    monkeypatch.setattr(observer_module, "milp_backend", milp)
    return rec


def _random_window(plant, rng):
    """Random window data: inputs inside U, outputs and prior anywhere in their ranges."""
    half, centre = plant.scales()
    n = plant.n
    U = centre[n:] + 0.9 * half[n:] * rng.uniform(-1, 1, size=(T, plant.m))
    Y = rng.uniform(-1, 1, size=(T, plant.p)) * 50.0
    xbar = centre[:n] + half[:n] * rng.uniform(-1, 1, size=n)
    return U, Y, xbar


def _mld_expected(F, p):
    """Normalised MLD rows and their bounds at the parameters ``p``, from CasADi's Jacobian."""
    fun = ca.Function("rows", [F.v, F.params], [ca.jacobian(F.mld_rows, F.v), F.mld_rows])
    Jv, r0 = (np.array(M.full()) for M in fun(np.zeros(F.v.numel()), p))
    r0 = r0.reshape(-1)
    norm = np.max(np.abs(Jv), axis=1)
    norm = np.where(norm > 0, norm, 1.0)
    return Jv / norm[:, None], (F.mld_lo - r0) / norm, (F.mld_hi - r0) / norm


def _close(a, b, rtol=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    fin = np.isfinite(b)
    assert np.array_equal(np.isfinite(a), fin)
    scale = max(1.0, float(np.max(np.abs(b[fin]), initial=0.0)))
    assert np.max(np.abs(a[fin] - b[fin]), initial=0.0) <= rtol * scale


CONFIGS = [{}, {"disturbance_weight": 2.0, "arrival_weight": [1.0, 0.1, 0.1]}]


@pytest.mark.parametrize("weights", CONFIGS, ids=["plain", "disturbance+arrival"])
def test_miqp_matrices_are_the_casadi_hessian_and_jacobians(plant, monkeypatch, weights):
    rec = _recording(monkeypatch)
    # the MIQP is solved even where its proximal certificate cannot prove the gap (the observer
    # skips it there and certifies by the prefix search)
    monkeypatch.setattr(MHEObserver, "_least_gap_bound", lambda self: 0.0)
    obs = MHEObserver(plant, T, settings=MHESettings(check_uniqueness=False, zero_cost_certificate=False), **weights)
    F = obs.formulation
    nv = F.v.numel()
    # the Hessian of the cost, by CasADi here, at a random point and random parameters
    rng = np.random.default_rng(1)
    Hfun = ca.Function("H", [F.v, F.params], [ca.hessian(F.cost, F.v)[0]])
    Hc = np.array(Hfun(rng.normal(size=nv), rng.normal(size=F.params.numel())).full())
    Js = 0.5 * np.max(np.diag(Hc))
    eps = np.where(obs.enc.discrete, obs.settings.binary_prox_weight, obs.settings.prox_weight)
    _close(rec["H"], Hc / Js + 2.0 * np.diag(eps))
    A, lo0, hi0 = _mld_expected(F, np.zeros(F.params.numel()))
    _close(rec["A"], A)
    _close(rec["lb"], obs.enc.lb)
    grad = ca.Function("g", [F.v, F.params], [ca.gradient(F.cost, F.v)])
    for trial in range(3):
        U, Y, xbar = _random_window(plant, rng)
        p = np.concatenate([U.reshape(-1), Y.reshape(-1), xbar])
        # the numpy maps the observer uses per step, at random parameters
        _, lo, hi = _mld_expected(F, p)
        lo_o, hi_o = obs.enc.bounds(U.reshape(-1))
        _close(lo_o, lo)
        _close(hi_o, hi)
        _close(obs.formulation.linear_term(p), np.array(grad(np.zeros(nv), p).full()).reshape(-1), rtol=1e-11)
        # ... and what DAQP receives in a solve
        rec["solves"].clear()
        obs.solve_window(U, Y, x_start=xbar)
        assert rec["solves"], "the branch and bound was not called"
        s = rec["solves"][0]
        _close(s["lo"], lo)
        _close(s["hi"], hi)
        g = np.array(grad(s["centre"], p).full()).reshape(-1)  # gradient at the proximal centre
        _close(s["f"], g / Js, rtol=1e-10)


@pytest.mark.parametrize("norm", ["1", "inf"])
def test_milp_matrices_are_the_casadi_jacobians(plant, monkeypatch, norm):
    rec = _recording(monkeypatch)
    obs = MHEObserver(plant, T, norm=norm, arrival_weight=[1.0, 0.1, 0.1],
                      settings=MHESettings(check_uniqueness=False, zero_cost_certificate=False))
    F = obs.formulation
    nz = F.z.numel()
    rng = np.random.default_rng(2)
    cfun = ca.Function("c", [F.z, F.params], [ca.jacobian(F.cost, F.z)])
    _close(rec["c"], np.array(cfun(rng.normal(size=nz), rng.normal(size=F.params.numel())).full()).reshape(-1))
    A_mld, _, _ = _mld_expected(F, np.zeros(F.params.numel()))
    efun = ca.Function("e", [F.z, F.params], [ca.jacobian(F.epigraph_rows, F.z), F.epigraph_rows])
    Ae, _ = efun(np.zeros(nz), np.zeros(F.params.numel()))
    ns = nz - F.v.numel()
    _close(rec["A"], np.vstack([np.hstack([A_mld, np.zeros((A_mld.shape[0], ns))]), np.array(Ae.full())]))
    _close(rec["lb"], np.concatenate([obs.enc.lb, np.zeros(ns)]))
    _close(rec["ub"], np.concatenate([obs.enc.ub, np.full(ns, np.inf)]))
    for trial in range(3):
        U, Y, xbar = _random_window(plant, rng)
        p = np.concatenate([U.reshape(-1), Y.reshape(-1), xbar])
        _, lo, hi = _mld_expected(F, p)
        e0 = np.array(efun(np.zeros(nz), p)[1].full()).reshape(-1)
        rec["solves"].clear()
        obs.solve_window(U, Y, x_start=xbar)
        assert rec["solves"], "HiGHS was not called"
        s = rec["solves"][0]
        _close(s["lo"], np.concatenate([lo, np.full(e0.size, -np.inf)]))
        _close(s["hi"], np.concatenate([hi, -e0]))


@pytest.mark.parametrize("norm, solvers", [("2", ("casadi-daqp", "bonmin")), ("1", ("cbc",)), ("inf", ("cbc",))])
def test_casadi_plugins_get_the_same_matrices(plant, monkeypatch, norm, solvers):
    """The CasADi plugins are fed from the same formulation (``casadi-highs`` cannot be built in a
    process that has loaded highspy, see the backends' docstrings)."""
    rec = _recording(monkeypatch)
    MHEObserver(plant, T, norm=norm, settings=MHESettings(check_uniqueness=False))
    ref = {k: rec[k] for k in ("A", "lb", "ub", "discrete") + (("H",) if norm == "2" else ("c",))}
    for solver in solvers:
        obs = MHEObserver(plant, T, norm=norm, solver=solver, settings=MHESettings(check_uniqueness=False))
        assert rec["solver"] == solver
        for k, val in ref.items():
            _close(rec[k], val, rtol=0.0)
        if solver == "cbc":  # what the plugin itself holds
            _close(np.array(ca.densify(obs._backend._A).full()), ref["A"], rtol=0.0)


# ---------------------------------------------------------------------- the extension hook
RHO = 1e-4
OFFSET = np.array([0.01, 1.0, 1.0])


def _pull(ext):
    x_ref = ext.add_parameter("x_ref", ext.n)
    w_min = ext.add_parameter("w_min", 1, value=-1e3)
    ext.add_cost(RHO * ca.sumsqr(ext.x[0] - x_ref))
    ext.add_constraint(ext.x[0][1] - w_min, lo=0.0)


def oracle(plant, U, Y, x_ref, w_min):
    """Least cost of the window over every mode sequence, by cvxpy + Clarabel (no hybobs_opt.mhe code).

    ``sum_k ||y(k) - C x(k) - D u(k) - c||^2 + RHO ||x(0) - x_ref||^2`` subject to the dynamics of
    each mode sequence, its guards, ``x(k) in X`` and ``x_1(0) >= w_min``.  The states are affine
    in the unit-box coordinates ``xi`` of ``x(0)``, propagated here through each mode's
    ``A_i, B_i, a_i``; a sequence whose rows have no point (scipy's HiGHS LP) is skipped, every
    other one must be solved (``optimal``), else the oracle cannot vouch for its minimum.
    """
    from scipy.optimize import linprog

    n = plant.n
    half, centre = plant.scales()
    hx, cx = half[:n], centre[:n]
    X = plant.state_bounds
    best = (np.inf, None, None)
    for seq in itertools.product(range(plant.n_modes), repeat=T):
        Px, px = np.diag(hx), cx.copy()  # x(k) = Px xi + px
        Rs, rs, Gs, gs = [np.sqrt(RHO) * Px], [np.sqrt(RHO) * (px - x_ref)], [], []
        for k, q in enumerate(seq):
            md = plant.modes[q]
            G, g = md.guard.A, md.guard.b
            Gs += [G[:, :n] @ Px, X.A @ Px]
            gs += [g - G[:, n:] @ U[k] - G[:, :n] @ px, X.b - X.A @ px]
            Rs.append(md.C @ Px)
            rs.append(md.C @ px + md.D @ U[k] + md.c - Y[k])
            Px, px = md.A @ Px, md.A @ px + md.B @ U[k] + md.a
        Gs.append(-np.eye(n)[1:2] * hx[1])
        gs.append(np.array([cx[1] - w_min]))
        R, r, G, g = np.vstack(Rs), np.concatenate(rs), np.vstack(Gs), np.concatenate(gs)
        scale = np.max(np.abs(G), axis=1)
        G, g = G / scale[:, None], g / scale
        lp = linprog(np.zeros(n), A_ub=G, b_ub=g, bounds=[(None, None)] * n, method="highs")
        if lp.status == 2:
            continue  # infeasible sequence
        assert lp.status == 0, lp.message
        xi = cp.Variable(n)
        prob = cp.Problem(cp.Minimize(cp.sum_squares(R @ xi + r)), [G @ xi <= g])
        try:  # tight tolerances (the optimum is ~1e-4 of outputs ~1e2)
            prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-13, tol_gap_rel=1e-11, tol_feas=1e-11, max_iter=500)
        except cp.error.SolverError:
            prob.solve(solver=cp.CLARABEL)
        assert prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE), (seq, prob.status)
        if prob.value < best[0]:
            best = (float(prob.value), seq, cx + hx * xi.value)
    return best


WINDOW_STARTS = (600, 1040, 1500, 2200)


@pytest.mark.parametrize("binding", [False, True], ids=["cost", "cost+binding-constraint"])
def test_extension_matches_brute_force_oracle(plant, noisy, binding):
    trace, Ynoisy = noisy
    obs = MHEObserver(plant, T, extend=_pull, settings=MHESettings(check_uniqueness=False))
    half = plant.scales()[0][: plant.n]
    searched = 0
    for s in WINDOW_STARTS:
        U, Y = trace.u[s:s + T], Ynoisy[s:s + T]
        x_ref = trace.x[s] + OFFSET
        w_min = trace.x[s][1] + (0.3 if binding else -1e3)
        obs.set_parameter("x_ref", x_ref)
        obs.set_parameter("w_min", w_min)
        got = obs.solve_window(U, Y, x_start=trace.x[s])
        opt, seq, x0 = oracle(plant, U, Y, x_ref, w_min)
        assert got["status"] == "optimal", got.to_dict()
        assert got["cost"] == pytest.approx(opt, rel=1e-6, abs=1e-12)
        assert np.max(np.abs(got["x_start"] - x0) / half) <= 1e-3
        if binding:
            assert got["x_start"][1] >= w_min - 1e-6 * half[1]
            assert got["x_start"][1] == pytest.approx(w_min, abs=1e-4 * half[1])  # it binds
        # the reported cost is the oracle's cost of the observer's own trajectory
        md_cost = RHO * float(np.sum((got["x_start"] - x_ref) ** 2)) + float(
            np.sum(obs.model.output_residuals(got["states"], got["modes"], U, Y) ** 2))
        assert got["cost"] == pytest.approx(md_cost, rel=1e-9, abs=1e-15)
        searched += "prefix search" in str(got["solved_by"])
    assert searched, "no window went through the exact prefix search (its node QPs carry the hook's terms)"


def test_prefix_nodes_carry_the_extension_terms(plant, noisy):
    """The prefix search's node QPs include the hook's terms on the variables the prefix fixes."""
    trace, Ynoisy = noisy
    s = 1040
    U, Y = trace.u[s:s + T], Ynoisy[s:s + T]
    plain = MHEObserver(plant, T, settings=MHESettings(check_uniqueness=False))
    ext = MHEObserver(plant, T, extend=_pull, settings=MHESettings(check_uniqueness=False))
    ext.set_parameter("x_ref", trace.x[s] + OFFSET)
    ext.model.set_parameters(np.concatenate([trace.x[s] + OFFSET, [trace.x[s][1] + 0.3]]))
    for seq in [(1,), (1, 1), (1, 1, 1)]:
        R0, r0, G0, g0, _ = plain.model.sequence_problem(seq, U, Y, trace.x[s])
        R1, r1, G1, g1, _ = ext.model.sequence_problem(seq, U, Y, trace.x[s])
        assert R1.shape[0] == R0.shape[0] + plant.n  # the pull's rows (on x(0): fixed by any prefix)
        assert G1.shape[0] == G0.shape[0] + 1  # the constraint on x(0)
        theta = np.zeros(R0.shape[1])
        extra = float(np.sum((R1 @ theta + r1) ** 2) - np.sum((R0 @ theta + r0) ** 2))
        x0 = ext.model.cx
        assert extra == pytest.approx(RHO * np.sum((x0 - trace.x[s] - OFFSET) ** 2), rel=1e-9)


def test_extension_with_uniqueness_runs(plant, noisy):
    trace, Ynoisy = noisy
    obs = MHEObserver(plant, T, extend=_pull)
    s = 600
    obs.set_parameter("x_ref", trace.x[s] + OFFSET)
    out = obs.solve_window(trace.u[s:s + T], Ynoisy[s:s + T], x_start=trace.x[s], uniqueness=True)
    assert out["status"] == "optimal"
    assert out["uniqueness"]["status"] in ("unique", "alternative", "not certified")


def test_extension_parameter_without_value_is_a_fallback(plant, noisy):
    trace, Ynoisy = noisy
    obs = MHEObserver(plant, T, extend=_pull, settings=MHESettings(check_uniqueness=False), x0=trace.x[600])
    flags = [obs.step(trace.u[k], Ynoisy[k]) for k in range(600, 600 + T)]
    assert flags[-1].flag == "fallback"
    assert "x_ref" in flags[-1].info["reason"]
    with pytest.raises(ModelError, match="name"):
        obs.set_parameter("nope", 1.0)
    with pytest.raises(ModelError, match="x_ref"):
        obs.set_parameter("x_ref", [1.0, 2.0])


def _hook(fn):
    return lambda ext: fn(ext)


@pytest.mark.parametrize("norm, fn, match", [
    ("2", lambda e: e.add_cost(e.x[0][0] ** 4), "quadratic"),
    ("2", lambda e: e.add_cost(-ca.sumsqr(e.x[0])), "convex"),
    ("2", lambda e: e.add_cost(e.x[0][0]), "curvature"),
    ("2", lambda e: e.add_cost(ca.sumsqr(e.x[0]) + e.delta[0][0]), "sum of squares"),
    ("2", lambda e: e.add_constraint(e.x[0][0] ** 2, hi=1.0), "affine"),
    ("2", lambda e: e.add_constraint(e.x[0][0] - e.y[0][0], hi=1.0), "not of the data"),
    ("2", lambda e: e.add_cost(ca.sumsqr(ca.SX.sym("stray") - e.x[0][0])), "free symbols"),
    ("1", lambda e: e.add_cost(ca.sumsqr(e.x[0])), "linear"),
    ("1", lambda e: e.add_cost(e.x[0][0] * e.add_parameter("c")), "linear"),
])
def test_extension_rejects_what_it_cannot_honour(plant, norm, fn, match):
    with pytest.raises(ModelError, match=match):
        MHEObserver(plant, T, norm=norm, extend=fn, settings=MHESettings(check_uniqueness=False))


def test_milp_extension_cost_refuses_uniqueness_and_zero_cost(plant):
    with pytest.raises(ModelError, match="check_uniqueness"):
        MHEObserver(plant, T, norm="1", extend=lambda e: e.add_cost(e.x[0][0]))
    obs = MHEObserver(plant, T, norm="1", extend=lambda e: e.add_cost(1e-3 * e.x[0][0]),
                      settings=MHESettings(check_uniqueness=False))
    assert obs.settings.zero_cost_certificate is False


# ---------------------------------------------------------------------- time budget
@pytest.mark.parametrize("bad", [0, -1.0, float("inf"), float("nan"), "1", True])
def test_certify_time_budget_is_validated(plant, bad):
    with pytest.raises(ModelError, match="certify_time_budget"):
        MHESettings(certify_time_budget=bad)


def test_tiny_time_budget_leaves_noisy_windows_fallback(plant, noisy):
    trace, Ynoisy = noisy
    first = 1000
    obs = MHEObserver(plant, T, x0=trace.x[first], fit_tolerance=5 * NOISE,
                      settings=MHESettings(certify_time_budget=1e-9))
    steps = [obs.step(trace.u[k], Ynoisy[k]) for k in range(first, first + 12)]
    active = steps[T - 1:]
    assert not any(e.flag == "observable" for e in active)
    hit = [e for e in active if "time budget" in str(e.info.get("reason", ""))]
    assert hit, [e.info.get("reason") for e in active]
    assert all(e.flag == "fallback" for e in hit)
    assert "certify_time_budget" in hit[0].info["reason"]
    # the same windows without the budget are certified
    free = MHEObserver(plant, T, x0=trace.x[first], fit_tolerance=5 * NOISE,
                       settings=MHESettings(check_uniqueness=False))
    assert any(free.step(trace.u[k], Ynoisy[k]).info.get("certified_optimum") for k in range(first, first + 12))


def test_prefix_search_stops_at_its_deadline(plant, noisy):
    import time

    from hybobs_opt.mhe import search_sequences

    trace, Ynoisy = noisy
    s = 1040
    obs = MHEObserver(plant, T, settings=MHESettings(check_uniqueness=False))
    U, Y = trace.u[s:s + T], Ynoisy[s:s + T]
    found = search_sequences(obs.model, U, Y, trace.x[s], None, rtol=1e-6, atol=0.0, max_nodes=10_000,
                             deadline=time.perf_counter() - 1.0, time_budget=0.5)
    assert not found.certified and not found.exhaustive
    assert "time budget of 0.5 s" in found.reason
    full = search_sequences(obs.model, U, Y, trace.x[s], None, rtol=1e-6, atol=obs._zero_cost, max_nodes=10_000,
                            deadline=time.perf_counter() + 600.0, time_budget=600.0)
    assert full.certified


def test_generous_time_budget_changes_nothing(plant, noisy):
    trace, Ynoisy = noisy
    first = 1000
    runs = []
    for budget in (None, 600.0):
        obs = MHEObserver(plant, T, x0=trace.x[first], fit_tolerance=5 * NOISE,
                          settings=MHESettings(certify_time_budget=budget, check_uniqueness=False))
        runs.append([obs.step(trace.u[k], Ynoisy[k]) for k in range(first, first + 8)])
    assert [e.flag for e in runs[0]] == [e.flag for e in runs[1]]
    assert np.allclose([e.x for e in runs[0]], [e.x for e in runs[1]], rtol=0, atol=1e-12)


C_LIN = 1e-3


def oracle_norm1(plant, U, Y, w_min):
    """Norm 1 with the linear term ``C_LIN * x_2(0)`` and ``x_2(0) >= w_min``: every mode sequence's
    LP by cvxpy + Clarabel, or scipy's HiGHS simplex where Clarabel fails (no hybobs_opt.mhe code;
    infeasible sequences by scipy's HiGHS LP)."""
    from scipy.optimize import linprog

    n = plant.n
    half, centre = plant.scales()
    hx, cx = half[:n], centre[:n]
    X = plant.state_bounds
    best = np.inf
    for seq in itertools.product(range(plant.n_modes), repeat=T):
        Px, px = np.diag(hx), cx.copy()
        Rs, rs, Gs, gs = [], [], [-np.eye(n)[1:2] * hx[1]], [np.array([cx[1] - w_min])]
        for k, q in enumerate(seq):
            md = plant.modes[q]
            G, g = md.guard.A, md.guard.b
            Gs += [G[:, :n] @ Px, X.A @ Px]
            gs += [g - G[:, n:] @ U[k] - G[:, :n] @ px, X.b - X.A @ px]
            Rs.append(md.C @ Px)
            rs.append(md.C @ px + md.D @ U[k] + md.c - Y[k])
            Px, px = md.A @ Px, md.A @ px + md.B @ U[k] + md.a
        R, r, G, g = np.vstack(Rs), np.concatenate(rs), np.vstack(Gs), np.concatenate(gs)
        scale = np.max(np.abs(G), axis=1)
        G, g = G / scale[:, None], g / scale
        if linprog(np.zeros(n), A_ub=G, b_ub=g, bounds=[(None, None)] * n, method="highs").status == 2:
            continue
        xi = cp.Variable(n)
        prob = cp.Problem(cp.Minimize(cp.norm1(R @ xi + r) + C_LIN * (cx[1] + hx[1] * xi[1])), [G @ xi <= g])
        try:
            prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-11, tol_feas=1e-11)
            ok = prob.status == cp.OPTIMAL
        except cp.error.SolverError:
            ok = False
        if ok:
            best = min(best, float(prob.value))
            continue
        # Clarabel fails on some of these LPs (sets without interior on the backlash planes): the
        # epigraph LP min 1't + c'xi, -t <= R xi + r <= t, G xi <= g by scipy's HiGHS simplex
        N = R.shape[0]
        c = np.concatenate([C_LIN * hx[1] * np.eye(n)[1], np.ones(N)])
        A_ub = np.vstack([np.hstack([R, -np.eye(N)]), np.hstack([-R, -np.eye(N)]), np.hstack([G, np.zeros((G.shape[0], N))])])
        b_ub = np.concatenate([-r, r, g])
        lp = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * (n + N), method="highs")
        assert lp.status == 0, (seq, lp.message)
        best = min(best, float(lp.fun + C_LIN * cx[1]))
    return best


def test_norm1_extension_matches_brute_force_oracle(plant, noisy):
    trace, Ynoisy = noisy

    def hook(ext):
        w_min = ext.add_parameter("w_min", 1)
        ext.add_cost(C_LIN * ext.x[0][1])
        ext.add_constraint(ext.x[0][1] >= w_min)  # a CasADi comparison

    obs = MHEObserver(plant, T, norm="1", extend=hook, settings=MHESettings(check_uniqueness=False))
    for s in WINDOW_STARTS[:3]:
        U, Y = trace.u[s:s + T], Ynoisy[s:s + T]
        w_min = trace.x[s][1] + 0.3
        obs.set_parameter("w_min", w_min)
        got = obs.solve_window(U, Y, x_start=trace.x[s])
        assert got["status"] == "optimal", got.to_dict()
        opt = oracle_norm1(plant, U, Y, w_min)
        assert got["cost"] == pytest.approx(opt, rel=1e-6, abs=1e-9)
        assert got["x_start"][1] >= w_min - 1e-7 * plant.scales()[0][1]
        resid = float(np.abs(obs.model.output_residuals(got["states"], got["modes"], U, Y)).sum())
        assert got["cost"] == pytest.approx(resid + C_LIN * got["x_start"][1], rel=1e-9)
