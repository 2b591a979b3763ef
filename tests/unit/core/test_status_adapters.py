"""Every solver adapter, fed every status its solver can return, accepts only the optimal ones (issue 13).

``tests/test_status.py`` checks the status tables; here the adapters' own code runs with the
solver call replaced by one that returns a chosen raw status *together with a perfectly good
point*, so an adapter that looked at the point instead of the status, or let an inaccurate or
limit status through, would be caught.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.errors import SolverError
from hybobs_opt.status import DAQP_EXIT_FLAGS, HIGHS_MODEL_STATUS, Status, map_status


# ---------------------------------------------------------------------------- HiGHS (geometry.lp.solve_lp)
@pytest.mark.parametrize("raw", sorted(HIGHS_MODEL_STATUS))
def test_solve_lp_accepts_only_highs_optimal(raw, monkeypatch):
    """HiGHS's real answer (point and multipliers) with its model status replaced by every member of
    ``HighsModelStatus``: only ``kOptimal`` gives a point; a limit or numerical trouble is an error
    after every HiGHS method; a claimed infeasibility or unboundedness of this feasible, bounded LP has
    no certificate that verifies, so it is an error too (issue 16: no verdict is trusted unchecked)."""
    from hybobs_opt.geometry import lp

    calls = []
    real = lp._call_highs

    def fake(c, A, b, E, e, bounds, method):
        calls.append(method)
        out = real(c, A, b, E, e, bounds, method)
        out.status, out.message = map_status(HIGHS_MODEL_STATUS, raw, solver="highspy"), f"status {raw}"
        return out

    monkeypatch.setattr(lp, "_call_highs", fake)
    A, b = np.array([[1.0], [-1.0]]), np.array([1.0, 1.0])
    try:
        res = lp.solve_lp(np.array([1.0]), A, b)
    except SolverError:
        assert raw != "kOptimal"
        assert {"highs", "highs-ipm", "highs-ds"} <= set(calls)  # every method tried (and its certificate LPs)
        return
    assert raw == "kOptimal" and res.status is Status.OPTIMAL
    np.testing.assert_allclose(res.x, [-1.0])


def test_solve_lp_reports_a_real_infeasibility_with_a_certificate():
    from hybobs_opt.geometry import lp

    A, b = np.array([[1.0], [-1.0]]), np.array([-1.0, -1.0])  # x <= -1 and x >= 1
    res = lp.solve_lp(np.array([1.0]), A, b)
    assert res.status is Status.INFEASIBLE and res.certificate.verify()


# ---------------------------------------------------------------------------- cvxpy (lmi.solve.solve_problem)
def _every_cvxpy_status():
    import cvxpy.settings as s

    return sorted(set(s.SOLUTION_PRESENT) | set(s.INF_OR_UNB) | set(s.ERROR) | {s.USER_LIMIT})


@pytest.mark.parametrize("raw", _every_cvxpy_status())
def test_solve_problem_and_the_observer_lmi_accept_only_cvxpy_optimal(raw, monkeypatch):
    import cvxpy as cp

    from hybobs_opt.lmi.solve import solve_problem

    x = cp.Variable()
    prob = cp.Problem(cp.Minimize(x), [x >= 0.0, x <= 1.0])

    def fake_solve(self, *args, **kwargs):
        x.value = np.array(0.0)  # a feasible, optimal point, whatever the status says
        self._status = raw

    # on the class: the fallback solvers run on sibling problems that share the constraints
    monkeypatch.setattr(cp.Problem, "solve", fake_solve)
    out = solve_problem(prob)
    assert out.optimal == (raw == cp.OPTIMAL)
    assert (out.status is Status.OPTIMAL) == (raw == cp.OPTIMAL)


@pytest.mark.parametrize("raw", ["optimal_inaccurate", "infeasible_inaccurate", "user_limit", "solver_error"])
def test_lmi_consumers_refuse_every_non_optimal_status(raw, monkeypatch):
    """The location observer's Luenberger LMI and the continuous observer LMI of paper 000."""
    import hybobs_opt.synthesis.continuous_design as ho
    import hybobs_opt.synthesis.location_design as ld
    from hybobs_opt.lmi.solve import SolveOutcome
    from hybobs_opt.studies.paper000_driveline.systems import driveline

    def fake(problem):
        for v in problem.variables():
            v.value = np.eye(v.shape[0]) if len(v.shape) == 2 and v.shape[0] == v.shape[1] else np.zeros(v.shape)
        return SolveOutcome(Status(raw) if raw in Status._value2member_map_ else Status.LIMIT, 0.0, 0.0, 0.0)

    monkeypatch.setattr(ld, "solve_problem", fake)
    monkeypatch.setattr(ho, "solve_problem", fake)
    aut = driveline(k=1000.0)
    with pytest.raises(SolverError):
        ho.design_continuous_observer(aut, 10.0, gain_bound=1e3)
    loc = aut.locations[0]
    lmi = ld.LuenbergerLMI(aut.n, aut.p, 1e3)
    with pytest.raises(SolverError):
        lmi.solve(loc.A, loc.C, 1.0, "test")


# ---------------------------------------------------------------------------- DAQP (MHE branch-and-bound)
@pytest.fixture(scope="module")
def mhe_window():
    from hybobs_opt.mhe import MHEObserver
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario, powertrain3

    plant = powertrain3()
    tr = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=0.05)
    return plant, tr


@pytest.mark.parametrize("name", sorted(DAQP_EXIT_FLAGS))
def test_daqp_backend_accepts_only_exit_flag_1(name, mhe_window, monkeypatch):
    from hybobs_opt.mhe import MHEObserver, MHESettings

    plant, tr = mhe_window
    # the MIQP is solved even where its proximal certificate cannot prove the gap (the observer
    # otherwise skips it and certifies by the prefix search)
    monkeypatch.setattr(MHEObserver, "_least_gap_bound", lambda self: 0.0)
    obs = MHEObserver(plant, 3, settings=MHESettings(check_uniqueness=False, zero_cost_certificate=False))
    k = 10
    good = obs.solve_window(tr.u[k:k + 3], tr.y[k:k + 3], x_start=tr.x[k])
    assert good.status is Status.OPTIMAL
    backend = obs._backend
    real_solve = backend._model.solve
    x, fval, flag, info = real_solve()  # a genuine optimal answer of the workspace
    raw = DAQP_EXIT_FLAGS[name]

    class Workspace:  # daqp.Model is a C type: a stand-in that answers ``raw`` with the good point
        settings: dict = {}

        def setup(self, *args):
            return 1

        def update(self, **kwargs):
            pass

        def solve(self):
            return x, fval, raw, info

    monkeypatch.setattr(backend, "_model", Workspace())
    out = backend.solve(np.zeros_like(x), -np.full(backend._A.shape[0], np.inf), np.full(backend._A.shape[0], np.inf))
    assert (out.status is Status.OPTIMAL) == (raw == DAQP_EXIT_FLAGS["OPTIMAL"])


# ---------------------------------------------------------------------------- HiGHS through highspy (MHE MILP)
def _highs_members():
    highspy = pytest.importorskip("highspy")
    return [m for m in highspy.HighsModelStatus.__members__.values()]


@pytest.mark.parametrize("member", _highs_members(), ids=lambda m: m.name)
def test_highspy_backend_accepts_only_k_optimal(member, mhe_window, monkeypatch):
    from hybobs_opt.mhe import MHEObserver, MHESettings

    plant, tr = mhe_window
    obs = MHEObserver(plant, 3, norm="1", settings=MHESettings(check_uniqueness=False, zero_cost_certificate=False))
    k = 10
    assert obs.solve_window(tr.u[k:k + 3], tr.y[k:k + 3], x_start=tr.x[k]).status is Status.OPTIMAL
    backend = obs._backend
    h = backend._h
    real = type(h).getModelStatus
    monkeypatch.setattr(type(h), "getModelStatus", lambda self: member)
    try:
        out = obs.solve_window(tr.u[k:k + 3], tr.y[k:k + 3], x_start=tr.x[k])
    finally:
        monkeypatch.setattr(type(h), "getModelStatus", real)
    assert (out.status is Status.OPTIMAL) == (member.name == "kOptimal"), (member.name, out.status)
