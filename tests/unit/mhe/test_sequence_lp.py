"""Solver ``"sequences"`` of the 1- / inf-norm MHE (paper 002, eq. 10; :mod:`hybobs_opt.mhe.sequence_lp`)
against an independent exact reference.

The reference is built here from the system matrices alone (it shares no code with
``sequence_lp.py`` or ``window.py``): every mode sequence of the window is one LP in the
window-start state, solved by ``scipy.optimize.linprog`` (HiGHS); the window's optimum is the best
sequence.  Uniqueness: for every sequence whose least cost is within ``J* + epsilon``, the LPs with
``+-(xi_k,j - xi*_k,j) >= delta`` at every window step ``k`` (scaled by the half-widths of ``X``:
the window start, the reported state and those between); the window is unique when none reaches
``J* + epsilon``.  Windows whose separated minimum lies within a small margin of the
threshold (a tie no tolerance can decide) are counted and left out of the flag comparison.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

from hybobs_opt import get_example
from hybobs_opt.defaults import NOISE_FIT_SIGMAS
from hybobs_opt.errors import ModelError
from hybobs_opt.mhe import MHEObserver, MHESettings
from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario
from hybobs_opt.tolerances import MHE_CERTIFIED_RTOL, SEQUENCE_LP_GAP_FLOOR

from canonical import deadzone_drive, deadzone_spring

NOISE = 0.01
#: Margin (original cost units) around the uniqueness threshold inside which the reference calls
#: a window a tie and the flags are not compared.
TIE = 1e-6


def _sequence_lp(system, modes, U, Y, norm, extra=None):
    """``min ||y - y^||`` over the window-start state for the fixed ``modes`` (linprog, HiGHS):
    ``(cost, x0)`` or ``(inf, None)`` when infeasible.  ``extra = (k, a, b)`` adds ``a' x_k >= b``
    on the window state ``x_k = Phi_k x0 + phi_k``."""
    n, p = system.n, system.p
    T = len(modes)
    Phi, phi = np.eye(n), np.zeros(n)
    Rrows, rvec, Arows, bvec = [], [], [], []
    XA, Xb = system.state_bounds.A, system.state_bounds.b
    sep = None
    for k, q in enumerate(modes):
        if extra is not None and extra[0] == k:
            sep = (extra[1] @ Phi, extra[2] - extra[1] @ phi)
        md = system.modes[q]
        # residual y_k - C x_k - D u_k - c = -C Phi x0 + (y_k - C phi - D u_k - c)
        Rrows.append(-md.C @ Phi)
        rvec.append(Y[k] - md.C @ phi - md.D @ U[k] - md.c)
        Ga, gb = md.guard.A, md.guard.b
        Arows.append(Ga[:, :n] @ Phi)
        bvec.append(gb - Ga[:, n:] @ U[k] - Ga[:, :n] @ phi)
        Arows.append(XA @ Phi)
        bvec.append(Xb - XA @ phi)
        Phi, phi = md.A @ Phi, md.A @ phi + md.B @ U[k] + md.a
    R, r = np.vstack(Rrows), np.concatenate(rvec)
    G, g = np.vstack(Arows), np.concatenate(bvec)
    k = R.shape[0]
    ns = k if norm == "1" else 1
    E = np.eye(k) if norm == "1" else np.ones((k, 1))
    # variables [x0; s]: R x0 + r <= E s, -(R x0 + r) <= E s, G x0 <= g
    A_ub = np.block([[R, -E], [-R, -E], [G, np.zeros((G.shape[0], ns))]])
    b_ub = np.concatenate([-r, r, g])
    if sep is not None:
        a, b = sep
        A_ub = np.vstack([A_ub, np.r_[-a, np.zeros(ns)]])
        b_ub = np.r_[b_ub, -b]
    c = np.r_[np.zeros(n), np.ones(ns)]
    out = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * n + [(0, None)] * ns, method="highs")
    if out.status == 2:
        return np.inf, None
    assert out.status == 0, out.message
    return float(out.fun), out.x[:n]


def _reference(system, U, Y, norm, x_states, delta, eps, half):
    """Brute force: the optimum over all sequences and whether a trajectory with a window state
    ``delta`` away from ``x_states`` at the same step (scaled by ``half``) reaches ``J* + eps``
    (``None``: a tie within :data:`TIE`)."""
    T = len(U)
    costs = {}
    for modes in itertools.product(range(system.n_modes), repeat=T):
        costs[modes] = _sequence_lp(system, modes, U, Y, norm)[0]
    J = min(costs.values())
    thr = J + eps
    lowest = np.inf
    for modes, cost in sorted(costs.items(), key=lambda kv: kv[1]):
        if cost > thr + TIE:
            continue
        for k in range(T):
            for j in range(system.n):
                for s in (1.0, -1.0):
                    a = np.zeros(system.n)
                    a[j] = s / half[j]
                    row = (k, a, s * x_states[k][j] / half[j] + delta)
                    lowest = min(lowest, _sequence_lp(system, modes, U, Y, norm, extra=row)[0])
                    if lowest < thr - TIE:
                        return J, False  # an alternative: no need to look further
    if abs(lowest - thr) <= TIE:
        return J, None
    return J, bool(lowest > thr)


def _certified_gap(obs, J):
    """The gap solver "sequences" certifies (the relative tolerance, its floor a fraction of the
    zero-cost threshold), plus the reference's own resolution (linprog's tolerances, 1e-9 here)."""
    return max(MHE_CERTIFIED_RTOL * J, SEQUENCE_LP_GAP_FLOOR * obs._zero_cost) + 1e-9


def _bench_data(steps=1500):
    plant = get_example("powertrain3").build()
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=steps * plant.Ts)
    Y = trace.y + np.random.default_rng(0).normal(0.0, NOISE, trace.y.shape)
    return plant, trace.u, Y


@pytest.fixture(scope="module")
def bench():
    return _bench_data()


def _windows(count: int, T: int, steps: int = 1500) -> list[int]:
    """Window starts: a third in the steady contact, the rest through the backlash rattle (900-1500)."""
    a = np.linspace(0, 899 - T, count // 3).astype(int)
    b = np.linspace(900, steps - T, count - count // 3).astype(int)
    return sorted(set(a.tolist() + b.tolist()))


def _check_against_reference(plant, U, Y, T, norm, starts, compare_highs: bool):
    obs = MHEObserver(plant, T, norm=norm, solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    ref_obs = MHEObserver(plant, T, norm=norm, solver="highs", fit_tolerance=NOISE_FIT_SIGMAS * NOISE) \
        if compare_highs else None
    half = plant.scales()[0][: plant.n]
    compared = ties = 0
    for i, k0 in enumerate(starts):
        Uw, Yw = U[k0:k0 + T], Y[k0:k0 + T]
        out = obs.solve_window(Uw, Yw, uniqueness=True)
        assert out.optimal, (k0, out.reason)
        J, unique = _reference(plant, Uw, Yw, norm, out.states, obs.settings.uniqueness_delta, obs.uniqueness_epsilon,
                               half)
        gap = _certified_gap(obs, J)
        assert abs(out.cost - J) <= gap, (k0, out.cost, J)
        status = out.uniqueness["status"]
        assert status in ("unique", "alternative"), (k0, out.uniqueness)
        if unique is None:
            ties += 1
        else:
            compared += 1
            assert (status == "unique") == unique, (k0, status, unique)
        if status == "alternative":
            alt = out.alternative
            assert alt["cost"] <= out.cost + obs.uniqueness_epsilon + 1e-12
            assert alt["distance"] >= obs.settings.uniqueness_delta - 1e-6
        if ref_obs is not None and i % 2 == 0:  # every other window (the MILP costs ~30 ms a window)
            other = ref_obs.solve_window(Uw, Yw, uniqueness=True)
            if other.optimal and other.uniqueness["status"] in ("unique", "alternative"):
                assert abs(other.cost - out.cost) <= gap + max(MHE_CERTIFIED_RTOL * other.cost, ref_obs._zero_cost)
                assert other.uniqueness["status"] == status, (k0, other.uniqueness, out.uniqueness)
                if status == "unique":
                    assert np.max(np.abs(other.x_start - out.x_start) / half) <= obs.settings.uniqueness_delta
    return compared, ties


@pytest.mark.parametrize("norm", ["1", "inf"])
def test_model16_T3_exact_against_brute_force_and_highs(bench, norm):
    plant, U, Y = bench
    starts = _windows(51, 3)
    compared, ties = _check_against_reference(plant, U, Y, 3, norm, starts, compare_highs=True)
    assert len(starts) >= 50 and compared >= 45, (compared, ties)


@pytest.mark.parametrize("norm", ["1", "inf"])
def test_model16_T4_exact_against_brute_force(bench, norm):
    plant, U, Y = bench
    starts = _windows(6, 4)
    compared, ties = _check_against_reference(plant, U, Y, 4, norm, starts, compare_highs=False)
    assert compared >= 5, (compared, ties)


def test_deadzone_spring_exact_against_brute_force():
    """A PWA system outside the papers (a dead-zone spring, tall windows T p > n: no exact fits, the
    LP branch and bound decides every window)."""
    plant = deadzone_spring()
    steps = 160
    u = deadzone_drive(steps)
    from hybobs_opt import simulate_pwa

    trace = simulate_pwa(plant, np.array([0.0, 0.0]), u)
    Y = trace.y + np.random.default_rng(1).normal(0.0, 0.01, trace.y.shape)
    T = 3
    obs = MHEObserver(plant, T, norm="1", solver="sequences")
    half = plant.scales()[0][: plant.n]
    seen = set()
    for k0 in range(0, steps - T, 9):
        out = obs.solve_window(u[k0:k0 + T], Y[k0:k0 + T], uniqueness=True)
        assert out.optimal, (k0, out.reason)
        J, unique = _reference(plant, u[k0:k0 + T], Y[k0:k0 + T], "1", out.states, obs.settings.uniqueness_delta,
                               obs.uniqueness_epsilon, half)
        assert abs(out.cost - J) <= _certified_gap(obs, J), (k0, out.cost, J)
        if unique is not None:
            assert (out.uniqueness["status"] == "unique") == unique, (k0, out.uniqueness)
        seen.add(out.uniqueness["status"])
    assert "unique" in seen


def test_observer_run_matches_highs_flags(bench):
    """The observer loop (warm multipliers across windows, the prefix retries) gives the flags of
    the MILP solver on a stretch with mode switches."""
    plant, U, Y = bench
    a = MHEObserver(plant, 3, norm="1", solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    b = MHEObserver(plant, 3, norm="1", solver="highs", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    flags = set()
    for k in range(960, 1000):
        ea, eb = a.step(U[k], Y[k]), b.step(U[k], Y[k])
        assert ea.flag == eb.flag, (k, ea.info.get("reason"), eb.info.get("reason"))
        flags.add(ea.flag)
        if ea.flag == "observable":
            assert np.allclose(ea.x, eb.x, rtol=1e-6, atol=1e-6)
    assert {"observable", "unobservable"} <= flags


@pytest.mark.parametrize("bad", [np.nan, 1e12])
def test_bad_sample_is_fallback(bench, bad):
    plant, U, Y = bench
    obs = MHEObserver(plant, 3, norm="1", solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    for k in range(5):
        obs.step(U[k], Y[k])
    est = obs.step(U[5], np.array([bad]))
    assert est.flag == "fallback"
    est = obs.step(U[6], Y[6])
    assert est.flag in ("fallback", "warming_up")


def test_refusals_and_options(bench):
    plant, U, Y = bench
    with pytest.raises(ModelError, match="sequences"):
        MHEObserver(plant, 3, norm="1", solver="sequences", settings=MHESettings(check_uniqueness=False),
                    extend=lambda ext: None)
    with pytest.raises(ModelError, match="lp"):
        MHEObserver(plant, 3, norm="1", solver="sequences", settings=MHESettings(solver_options={"lp": "gurobi"}))
    with pytest.raises(ModelError, match="solver"):
        MHEObserver(plant, 3, norm="2", solver="sequences")
    # the solver's own refusal of norm 2 (the observer refuses first; a direct caller reaches this one)
    from hybobs_opt.mhe.sequence_lp import SequenceLPSolver

    with pytest.raises(ModelError, match="'1' or 'inf'"):
        SequenceLPSolver(MHEObserver(plant, 3, norm="2").model, 0.0, None)
    # check_uniqueness=False: a certified optimum is observable without the separated LPs
    obs = MHEObserver(plant, 3, norm="1", solver="sequences",
                      settings=MHESettings(check_uniqueness=False, solver_options={"lp": "highs"}))
    flags = [obs.step(U[k], Y[k]).flag for k in range(6)]
    assert flags[2:] == ["observable"] * 4


def test_a_refused_lp_is_a_fallback_that_names_the_problem(bench):
    """The one SolverError the module raises (HiGHS refusing a prefix LP) carries the problem, the
    solver, the status and what to try; inside the observer it is a fallback with that reason,
    never a crash or a flag."""
    from hybobs_opt.errors import SolverError

    plant, U, Y = bench
    obs = MHEObserver(plant, 3, norm="1", solver="sequences", settings=MHESettings(solver_options={"lp": "highs"}))
    seq = obs._sequences
    real = seq._hs

    class RefusingHighs:
        def __init__(self):
            self._h = real.Highs()

        def passModel(self, lp):  # noqa: N802 - HiGHS's name
            return real.HighsStatus.kError

        def __getattr__(self, name):
            return getattr(self._h, name)

    class RefusingModule:
        Highs = RefusingHighs

        def __getattr__(self, name):
            return getattr(real, name)

    seq._hs = RefusingModule()
    for nd in seq.nodes:
        nd.lp = None
    with pytest.raises(SolverError) as exc:
        seq._lp_model(seq.nodes[0])
    err = exc.value
    assert err.solver == "highs" and "passModel" in err.status and "mode prefix" in err.problem
    assert "daqp" in str(err)
    flags = [obs.step(U[k], Y[k]) for k in range(6)]
    assert all(e.flag in ("warming_up", "fallback") for e in flags), [e.flag for e in flags]
    reasons = " ".join(str(e.info.get("reason", "")) for e in flags[2:])
    assert "SolverError" in reasons and "TypeError" not in reasons, reasons


def _brute_force_optimum(system, U, Y, norm="1"):
    return min(_sequence_lp(system, modes, U, Y, norm)[0]
               for modes in itertools.product(range(system.n_modes), repeat=len(U)))


def _noisy_windows(T, count):
    plant, U, Y = _bench_data(1200)
    return plant, [(U[k0:k0 + T], Y[k0:k0 + T]) for k0 in np.linspace(880, 1200 - T, count).astype(int)]


def test_lazy_tables_agree_with_eager_ones_and_brute_force():
    """The lazy prefix tree (nodes made on first visit, a child's rows appended to its parent's)
    holds the same matrices and affine maps as the eager one, and both give the brute-force
    optimum of the same windows."""
    plant, windows = _noisy_windows(3, 8)
    make = lambda tables: MHEObserver(plant, 3, norm="1", solver="sequences",  # noqa: E731
                                      settings=MHESettings(check_uniqueness=False,
                                                           solver_options={"tables": tables}))
    eager, lazy = make("eager"), make("lazy")
    assert not eager._sequences.lazy and lazy._sequences.lazy
    assert len(lazy._sequences.nodes) == len(lazy._sequences.roots) < len(eager._sequences.nodes)
    for Uw, Yw in windows:
        J = _brute_force_optimum(plant, Uw, Yw)
        a, b = eager.solve_window(Uw, Yw), lazy.solve_window(Uw, Yw)
        assert a.optimal and b.optimal, (a.reason, b.reason)
        for out, obs in ((a, eager), (b, lazy)):
            assert abs(out.cost - J) <= _certified_gap(obs, J), (out.cost, J)
            assert out.gap_bound <= _certified_gap(obs, out.cost)
    seq_e, seq_l = eager._sequences, lazy._sequences
    compared = 0
    for nd in seq_e.nodes:
        other = seq_l._path(nd.modes) if nd.leaf else None
        if other is None:
            continue
        compared += 1
        for x, y in zip(seq_e._maps(nd), seq_l._maps(other)):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
        np.testing.assert_allclose(nd.R, other.R, rtol=0, atol=1e-12)
        np.testing.assert_allclose(nd.G, other.G, rtol=0, atol=1e-12)
    assert compared == len(seq_e.leaves)


def test_memory_budget_refused_before_the_work_with_the_predicted_figure():
    plant = get_example("powertrain3").build()
    with pytest.raises(ModelError, match=r"memory_budget.*at least [\d,]+ bytes") as exc:
        MHEObserver(plant, 10, norm="1", solver="sequences",
                    settings=MHESettings(check_uniqueness=False, solver_options={"memory_budget": 20_000}))
    assert "20,000 bytes" in str(exc.value)
    with pytest.raises(ModelError, match="memory_budget"):
        MHEObserver(plant, 3, norm="1", solver="sequences", settings=MHESettings(solver_options={"memory_budget": 0}))
    # a budget that holds one path to a leaf but not a window's search: the step is refused with
    # the bytes it would need (a fallback naming the setting), and the tree never exceeds it
    _, windows = _noisy_windows(8, 1)
    from hybobs_opt.mhe.sequence_lp import SequenceLPSolver

    probe = MHEObserver(plant, 8, norm="1", solver="sequences", settings=MHESettings(check_uniqueness=False))
    path = sum(3 * probe._sequences._node_bytes(k) for k in range(1, 9))
    budget = path + 20_000
    obs = MHEObserver(plant, 8, norm="1", solver="sequences",
                      settings=MHESettings(check_uniqueness=False, solver_options={"memory_budget": budget}))
    assert isinstance(obs._sequences, SequenceLPSolver) and obs._sequences.lazy
    out = obs.solve_window(*windows[0])
    assert not out.optimal and "memory_budget" in out.reason and "at least" in out.reason, out.reason
    assert obs._sequences.tree_bytes <= budget


def test_search_stopped_early_reports_its_gap_not_a_certified_optimum():
    """``certify_max_nodes`` LPs stop the search: the window is not certified, and its incumbent's
    cost and proven lower bound bracket the brute-force optimum."""
    plant, windows = _noisy_windows(4, 4)
    stopped = 0
    for Uw, Yw in windows:
        J = _brute_force_optimum(plant, Uw, Yw)
        obs = MHEObserver(plant, 4, norm="1", solver="sequences",
                          settings=MHESettings(check_uniqueness=False, certify_max_nodes=1,
                                               solver_options={"tables": "lazy"}))
        out = obs.solve_window(Uw, Yw)
        if out.optimal:  # closed within one LP: then it is the optimum
            assert abs(out.cost - J) <= _certified_gap(obs, J)
            continue
        stopped += 1
        assert "certify_max_nodes" in out.reason and "relative gap" in out.reason, out.reason
        lower = out.solver_detail["lower_bound"]
        assert lower <= J + 1e-9
        if out.cost is not None:
            assert out.cost >= J - 1e-9
            assert out.gap_bound == pytest.approx(out.cost - lower, rel=1e-9, abs=1e-15)
            assert out.solver_detail["relative_gap"] == pytest.approx(out.gap_bound / out.cost, rel=1e-9)
    assert stopped >= 3


def test_at_the_memory_budget_unused_solver_models_are_freed_and_the_optima_unchanged():
    """A budget below what the run's tree grows to: the solver models not used in the current
    window are freed (least recently used first) and made again when needed; the windows keep the
    optima of an unbounded tree, the charged bytes never exceed the budget, and a window whose own
    search needs more is refused naming the setting."""
    plant, U, Y = _bench_data(1200)
    make = lambda extra: MHEObserver(plant, 5, norm="1", solver="sequences",  # noqa: E731
                                     settings=MHESettings(check_uniqueness=False,
                                                          solver_options={"tables": "lazy", **extra}))
    free, bounded = make({}), make({"memory_budget": 12_000_000})
    certified = 0
    for k0 in range(880, 900):
        a, b = free.solve_window(U[k0:k0 + 5], Y[k0:k0 + 5]), bounded.solve_window(U[k0:k0 + 5], Y[k0:k0 + 5])
        assert a.optimal, a.reason
        assert bounded._sequences.tree_bytes <= 12_000_000
        if b.optimal:
            certified += 1
            assert abs(a.cost - b.cost) <= _certified_gap(free, a.cost), (k0, a.cost, b.cost)
        else:
            assert "memory_budget" in b.reason, b.reason
    assert free._sequences.tree_bytes > 12_000_000
    assert bounded._sequences.models_freed > 0 and certified >= 17


# ------------------------------------------------------------------ later window states in the tree
def _pruned_reference(system, U, Y, norm, x_states, delta, eps, half):
    """:func:`_reference` for longer windows: the sequences whose prefix LPs (a lower bound of
    every extension: the cost is a sum, or a max, over the samples) stay within the best leaf's
    cost plus ``eps``, depth first; then every window state of those sequences separated."""
    T = len(U)
    leaves, stack, J = {}, [()], np.inf
    while stack:
        pre = stack.pop()
        for q in range(system.n_modes):
            seq = pre + (q,)
            c = _sequence_lp(system, seq, U[:len(seq)], Y[:len(seq)], norm)[0]
            if c > J + eps + TIE:
                continue
            if len(seq) == T:
                leaves[seq] = c
                J = min(J, c)
            else:
                stack.append(seq)
    thr, lowest = J + eps, np.inf
    for modes, cost in sorted(leaves.items(), key=lambda kv: kv[1]):
        if cost > thr + TIE:
            continue
        for k, j, s in itertools.product(range(T), range(system.n), (1.0, -1.0)):
            a = np.zeros(system.n)
            a[j] = s / half[j]
            lowest = min(lowest, _sequence_lp(system, modes, U, Y, norm, extra=(k, a, s * x_states[k][j] / half[j] + delta))[0])
            if lowest < thr - TIE:
                return J, False
    return J, (None if abs(lowest - thr) <= TIE else bool(lowest > thr))


def test_lazy_tree_separates_every_window_state_like_the_brute_force(bench):
    """T = 6 (a lazy tree) on noisy windows of model (16), steady and through the backlash rattle:
    the flag is the pruned brute force's over every window state, and it is decided in the tree
    (no MILP), one window by an alternative."""
    plant, U, Y = bench
    T = 6
    obs = MHEObserver(plant, T, norm="1", solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    assert obs._sequences.lazy
    half = plant.scales()[0][: plant.n]
    seen = []
    for k0 in (300, 1290, 1420):
        Uw, Yw = U[k0:k0 + T], Y[k0:k0 + T]
        out = obs.solve_window(Uw, Yw, uniqueness=True)
        assert out.optimal, (k0, out.reason)
        J, unique = _pruned_reference(plant, Uw, Yw, "1", out.states, obs.settings.uniqueness_delta,
                                      obs.uniqueness_epsilon, half)
        assert abs(out.cost - J) <= _certified_gap(obs, J), (k0, out.cost, J)
        uq = out.uniqueness
        assert unique is not None and (uq["status"] == "unique") == unique, (k0, uq, unique)
        assert uq["status"] in ("unique", "alternative") and "milp_directions" not in uq, (k0, uq)
        seen.append(uq["status"])
    assert seen.count("alternative") >= 1 and seen.count("unique") >= 1, seen


def test_row_bounds_are_valid_for_any_multipliers_and_tight_at_the_lp_duals(bench):
    """The bound of a later state's separation row (weak duality, best row multiplier by line
    search) never exceeds the separated LP's minimum computed independently (linprog on the
    unscaled window-start state), for random multipliers in the dual ball and random ``lam >= 0``;
    the separated LP's own answer bounds it to the LP's resolution."""
    plant, U, Y = bench
    T = 4
    obs = MHEObserver(plant, T, norm="1", solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    sl = obs._sequences
    half = plant.scales()[0][: plant.n]
    rng = np.random.default_rng(3)
    k0 = 1000
    Uw, Yw = U[k0:k0 + T], Y[k0:k0 + T]
    out = obs.solve_window(Uw, Yw, uniqueness=False)
    xs = obs._separated.optimum_states(out)
    later = np.flatnonzero(obs._separated.allowed(xs, range(1, T)))
    ctx = obs._sequences_ctx
    checked = finite = 0
    for modes in [tuple(out.modes), (0,) * T, (1,) * T, (2, 1, 1, 0)]:
        nd = sl._path(modes)
        if nd is None:
            continue
        r, g, _ = sl._data(nd, ctx)
        A, beta = sl._later_rows(nd, Uw, xs, later)
        for i, d in enumerate(later):
            k, j = (d // 2) // plant.n, (d // 2) % plant.n
            s = 1.0 if d % 2 == 0 else -1.0
            a = np.zeros(plant.n)
            a[j] = s / half[j]
            ref = _sequence_lp(plant, modes, Uw, Yw, "1", extra=(k, a, s * out.states[k][j] / half[j]
                                                                    + obs.settings.uniqueness_delta))[0]
            MU = rng.uniform(-1, 1, size=(20, r.size))
            LAM = rng.exponential(1.0, size=(20, g.size)) * (rng.random((20, g.size)) < 0.3)
            b = sl._row_bounds(nd, MU, LAM, r, g, np.tile(A[i], (20, 1)), np.full(20, beta[i]))
            assert np.all(b <= ref + 1e-9 * (1 + abs(ref))), (modes, d, b.max(), ref)
            exact = sl._solve_row_lp(nd, r, g, A[i], beta[i])
            assert exact is not None
            assert exact[0] <= ref + 1e-9 * (1 + abs(ref)), (modes, d, exact[0], ref)
            if np.isfinite(ref):
                finite += 1
                assert exact[0] >= ref - 1e-7 * (1 + ref) and abs(exact[2] - ref) <= 1e-7 * (1 + ref), (modes, d, exact, ref)
            else:
                assert exact[0] == np.inf, (modes, d, exact[0])
            checked += 1
    assert checked >= 50 and finite >= 10, (checked, finite)


def test_later_directions_the_lps_leave_open_go_to_the_milp_alone(bench, monkeypatch):
    """A separated LP without a checked answer leaves its direction undecided: those directions
    alone go to the MILP over every sequence (``milp_directions``), which gives the brute-force
    verdict."""
    from hybobs_opt.mhe.sequence_lp import SequenceLPSolver

    plant, U, Y = bench
    T = 3
    obs = MHEObserver(plant, T, norm="1", solver="sequences", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    half = plant.scales()[0][: plant.n]
    monkeypatch.setattr(SequenceLPSolver, "_solve_row_lp", lambda self, *a: None)
    real = SequenceLPSolver._row_bounds
    monkeypatch.setattr(SequenceLPSolver, "_row_bounds",
                        lambda self, nd, MU, *a: np.minimum(real(self, nd, MU, *a), -1.0))
    sent = 0
    for k0 in (300, 1010, 1420):
        Uw, Yw = U[k0:k0 + T], Y[k0:k0 + T]
        out = obs.solve_window(Uw, Yw, uniqueness=True)
        uq = out.uniqueness
        J, unique = _reference(plant, Uw, Yw, "1", out.states, obs.settings.uniqueness_delta, obs.uniqueness_epsilon,
                               half)
        if uq.get("milp_directions"):
            sent += 1
            assert uq["row_lps"] >= uq["milp_directions"] >= 1, uq
        if unique is not None:
            assert (uq["status"] == "unique") == unique, (k0, uq, unique)
    assert sent >= 2, sent
