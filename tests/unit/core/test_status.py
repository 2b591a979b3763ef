"""The one status vocabulary, its solver maps, and the result/certificate protocols (issue 13).

Every adapter table is fed every status its solver can return: enumerated from the solver library
where it exposes them (``cvxpy.settings``, ``highspy.HighsModelStatus``), from the documented lists
otherwise (linprog's 0-4, DAQP's ``constants.h`` exit flags, the strings of CasADi's HiGHS, CBC and
Bonmin interfaces).  Only the optimal answers may pass :func:`is_optimal`.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from hybobs_opt.results import Certificate, SolveResult
from hybobs_opt.status import (
    CASADI_BONMIN_STATUS,
    CASADI_CBC_STATUS,
    CASADI_HIGHS_STATUS,
    CVXPY_STATUS,
    DAQP_EXIT_FLAGS,
    DAQP_STATUS,
    HIGHS_MODEL_STATUS,
    LINPROG_STATUS,
    STATUS_TABLES,
    Status,
    highs_status,
    is_infeasible,
    is_optimal,
    map_status,
)

OLD_STRINGS = {
    "OPTIMAL": "optimal", "OPTIMAL_INACCURATE": "optimal_inaccurate", "INFEASIBLE": "infeasible",
    "INFEASIBLE_INACCURATE": "infeasible_inaccurate", "UNBOUNDED": "unbounded",
    "UNBOUNDED_INACCURATE": "unbounded_inaccurate", "INFEASIBLE_OR_UNBOUNDED": "infeasible_or_unbounded",
    "LIMIT": "limit", "FEASIBLE": "feasible", "NOT_CERTIFIED": "not certified",
    "INCUMBENT_OPTIMAL": "incumbent optimal", "SOLVER_ERROR": "solver_error", "UNKNOWN": "unknown",
}


# ---------------------------------------------------------------------------- the vocabulary
@pytest.mark.parametrize("name,value", sorted(OLD_STRINGS.items()))
def test_status_values_are_the_old_json_strings(name, value):
    st = Status[name]
    assert st == value and str(st) == value and f"{st}" == value
    assert json.dumps(st) == json.dumps(value)
    assert json.dumps({"status": st}) == json.dumps({"status": value})
    assert json.loads(json.dumps({st: 1})) == {value: 1}  # as a dict key (the solve counters)
    assert repr(st) == repr(value)  # messages formatted with !r read as before
    assert Status(value) is st


def test_only_optimal_is_optimal_and_only_infeasible_is_infeasible():
    for st in Status:
        assert is_optimal(st) == (st is Status.OPTIMAL)
        assert is_infeasible(st) == (st is Status.INFEASIBLE)
    assert is_optimal("optimal") and not is_optimal("optimal_inaccurate") and not is_optimal(None)


@pytest.mark.parametrize("solver", sorted(STATUS_TABLES))
def test_unknown_raw_values_map_to_unknown(solver):
    table = STATUS_TABLES[solver]
    for raw in (None, "no such status", 12345, -999, ("x", "y"), ["unhashable"], {"a": 1}, float("nan")):
        assert map_status(table, raw, solver=solver) is Status.UNKNOWN


@pytest.mark.parametrize("solver", sorted(STATUS_TABLES))
def test_every_table_value_is_a_status(solver):
    for raw, st in STATUS_TABLES[solver].items():
        assert isinstance(st, Status), (solver, raw)


def _accepted(table, raws, solver):
    return {raw for raw in raws if is_optimal(map_status(table, raw, solver=solver))}


# ---------------------------------------------------------------------------- cvxpy
def test_cvxpy_every_status_of_cvxpy_settings():
    import cvxpy.settings as s

    raws = set(s.SOLUTION_PRESENT) | set(s.INF_OR_UNB) | set(s.ERROR)
    raws |= {getattr(s, k) for k in ("OPTIMAL", "OPTIMAL_INACCURATE", "INFEASIBLE", "INFEASIBLE_INACCURATE",
                                     "UNBOUNDED", "UNBOUNDED_INACCURATE", "INFEASIBLE_OR_UNBOUNDED", "USER_LIMIT",
                                     "SOLVER_ERROR") if hasattr(s, k)}
    raws.add("solver_error")  # the package's own status for a solver that raised
    assert raws <= set(CVXPY_STATUS), raws - set(CVXPY_STATUS)
    assert _accepted(CVXPY_STATUS, raws, "cvxpy") == {s.OPTIMAL}
    assert map_status(CVXPY_STATUS, s.INFEASIBLE, solver="cvxpy") is Status.INFEASIBLE
    assert map_status(CVXPY_STATUS, s.USER_LIMIT, solver="cvxpy") is Status.LIMIT


def test_cvxpy_status_helper_on_a_compiled_problem():
    import cvxpy as cp

    from hybobs_opt.lmi.solve import cvxpy_status, solve_problem

    x = cp.Variable()
    lo = cp.Parameter(value=0.0)
    prob = cp.Problem(cp.Minimize(x), [x >= lo, x <= 1.0])
    assert cvxpy_status(prob) is Status.UNKNOWN  # not solved yet
    out = solve_problem(prob)
    assert out.status is Status.OPTIMAL and cvxpy_status(prob) is Status.OPTIMAL
    assert isinstance(out, SolveResult) and out.residuals and max(out.residuals.values()) <= 1e-6
    assert json.loads(json.dumps(out.to_dict()))["status"] == "optimal"
    lo.value = 2.0
    out = solve_problem(prob)
    assert out.status is Status.INFEASIBLE and out.residuals == {}


# ---------------------------------------------------------------------------- linprog
def test_linprog_documented_statuses():
    raws = [0, 1, 2, 3, 4]  # scipy.optimize.linprog: success, limit, infeasible, unbounded, numerical
    assert set(raws) == set(LINPROG_STATUS)
    assert _accepted(LINPROG_STATUS, raws, "linprog") == {0}
    assert [map_status(LINPROG_STATUS, r, solver="linprog") for r in raws] == [
        Status.OPTIMAL, Status.LIMIT, Status.INFEASIBLE, Status.UNBOUNDED, Status.SOLVER_ERROR]


def test_linprog_live_statuses_through_solve_lp():
    from hybobs_opt.geometry.lp import LPResult, solve_lp

    A = np.array([[1.0], [-1.0]])
    ok = solve_lp(np.array([1.0]), A, np.array([1.0, 1.0]))
    assert ok.status is Status.OPTIMAL and isinstance(ok, LPResult) and isinstance(ok, SolveResult)
    assert set(ok.residuals) >= {"inequality", "bounds"} and ok.residuals["inequality"] <= 1e-9
    assert ok.seconds >= 0.0 and json.loads(json.dumps(ok.to_dict()))["status"] == "optimal"
    assert solve_lp(np.array([1.0]), A, np.array([-1.0, -1.0])).status is Status.INFEASIBLE
    assert solve_lp(np.array([1.0]), np.array([[1.0]]), np.array([1.0])).status is Status.UNBOUNDED


# ---------------------------------------------------------------------------- DAQP
def test_daqp_every_exit_flag():
    raws = list(DAQP_EXIT_FLAGS.values())
    assert set(raws) == set(DAQP_STATUS)
    # soft optimal (2) is optimal only with the soft constraints relaxed: not accepted
    assert _accepted(DAQP_STATUS, raws, "daqp") == {DAQP_EXIT_FLAGS["OPTIMAL"]}
    assert map_status(DAQP_STATUS, DAQP_EXIT_FLAGS["INFEASIBLE"], solver="daqp") is Status.INFEASIBLE
    for name in ("CYCLE", "ITERLIMIT", "TIMELIMIT"):
        assert map_status(DAQP_STATUS, DAQP_EXIT_FLAGS[name], solver="daqp") is Status.LIMIT


def test_daqp_live_flags():
    import daqp

    H, f = np.zeros((1, 1)), np.array([-1.0])
    sense = np.zeros(2, dtype=np.int32)
    A = np.array([[1.0], [-1.0]])
    _, _, flag, _ = daqp.solve(H, f, A, np.array([1.0, 1.0]), np.full(2, -1e30), sense, eps_prox=1e-6)
    assert map_status(DAQP_STATUS, flag, solver="daqp") is Status.OPTIMAL
    _, _, flag, _ = daqp.solve(H, f, A, np.array([-1.0, -1.0]), np.full(2, -1e30), sense, eps_prox=1e-6)
    assert map_status(DAQP_STATUS, flag, solver="daqp") is Status.INFEASIBLE


# ---------------------------------------------------------------------------- HiGHS
def test_highspy_every_model_status_member():
    highspy = pytest.importorskip("highspy")

    members = dict(highspy.HighsModelStatus.__members__)
    assert set(members) == set(HIGHS_MODEL_STATUS), set(members) ^ set(HIGHS_MODEL_STATUS)
    accepted = {name for name, m in members.items() if is_optimal(highs_status(m))}
    assert accepted == {"kOptimal"}
    assert highs_status(highspy.HighsModelStatus.kInfeasible) is Status.INFEASIBLE
    assert highs_status(7) is Status.UNKNOWN  # a bare int is not a member: never guessed


def test_casadi_highs_strings_are_highs_model_status_strings():
    highspy = pytest.importorskip("highspy")

    h = highspy.Highs()
    strings = {h.modelStatusToString(m): name for name, m in highspy.HighsModelStatus.__members__.items()}
    assert set(strings) == set(CASADI_HIGHS_STATUS)
    for text, name in strings.items():
        assert CASADI_HIGHS_STATUS[text] is HIGHS_MODEL_STATUS[name]
    assert _accepted(CASADI_HIGHS_STATUS, strings, "casadi-highs") == {"Optimal"}


# ---------------------------------------------------------------------------- CasADi CBC, Bonmin
CBC_PRIMARY = ("before branchAndBound", "finished", "stopped - on maxnodes, maxsols, maxtime",
               "difficulties so run was abandoned", "stopped by event handler", "unknown")
CBC_SECONDARY = ("unset", "search completed with solution", "linear relaxation not feasible (or worse than cutoff)",
                 "stopped on gap", "stopped on nodes", "stopped on time", "stopped on user event",
                 "stopped on solutions", "node", "treeStatus", "solution", "heuristicSolution", "beforeSolution1",
                 "beforeSolution2", "afterHeuristic", "smallBranchAndBound", "heuristicPass", "convertToCuts",
                 "endSearch", "unknown")


def test_cbc_every_status_pair():
    pairs = [(p, s) for p in CBC_PRIMARY for s in CBC_SECONDARY]
    assert set(CASADI_CBC_STATUS) <= set(pairs)
    assert _accepted(CASADI_CBC_STATUS, pairs, "cbc") == {("finished", "search completed with solution")}
    assert map_status(CASADI_CBC_STATUS, ("finished", "stopped on gap"), solver="cbc") is Status.FEASIBLE


BONMIN = ("SUCCESS", "INFEASIBLE", "CONTINUOUS_UNBOUNDED", "LIMIT_EXCEEDED", "USER_INTERRUPT", "MINLP_ERROR",
          "Unknown", "Unset")


def test_bonmin_every_return_status():
    assert set(BONMIN) == set(CASADI_BONMIN_STATUS)
    assert _accepted(CASADI_BONMIN_STATUS, BONMIN, "bonmin") == {"SUCCESS"}
    assert map_status(CASADI_BONMIN_STATUS, "INFEASIBLE", solver="bonmin") is Status.INFEASIBLE


def test_casadi_live_cbc_and_bonmin_strings_are_in_the_tables():
    ca = pytest.importorskip("casadi")
    import contextlib
    import io

    A = ca.DM([[1.0, 1.0]])
    with contextlib.redirect_stdout(io.StringIO()):
        s = ca.conic("t_cbc", "cbc", {"a": ca.Sparsity.dense(1, 2), "h": ca.Sparsity(2, 2)},
                     {"discrete": [True, False], "error_on_fail": False, "cbc": {"loglevel": 0}})
        seen = []
        for lba in (0.5, 10.0):
            s(g=ca.DM([1.0, 1.0]), a=A, lba=lba, uba=ca.inf, lbx=0, ubx=1)
            st = s.stats()
            seen.append(map_status(CASADI_CBC_STATUS, (st["return_status"], st["secondary_return_status"]), solver="cbc"))
        x = ca.SX.sym("x", 2)
        b = ca.nlpsol("t_bonmin", "bonmin", {"x": x, "f": ca.sumsqr(x), "g": x[0] + x[1]},
                      {"discrete": [True, False], "error_on_fail": False, "print_time": False,
                       "bonmin": {"print_level": 0, "bb_log_level": 0, "nlp_log_level": 0}})
        for lbg in (0.5, 10.0):
            b(x0=0, lbg=lbg, ubg=ca.inf, lbx=0, ubx=1)
            seen.append(map_status(CASADI_BONMIN_STATUS, b.stats()["return_status"], solver="bonmin"))
    assert seen == [Status.OPTIMAL, Status.INFEASIBLE, Status.OPTIMAL, Status.INFEASIBLE]


# ---------------------------------------------------------------------------- protocols
def _certificates():
    """One instance of every certificate class that needs no solve (small exact examples).

    :class:`DualCertificate` needs an LMI's matrices; its instances are checked in test_lmi.py
    and here at class level.
    """
    from hybobs_opt.lmi.certificates import InfeasibilityCertificate
    from hybobs_opt.synthesis import periodic_gains as per

    A = np.array([[[0.5, 0.0], [0.0, 0.5]]])
    C = np.array([[1.0, 0.0]])
    return [
        InfeasibilityCertificate("r", "Theorem 4", "(8)", 0.0, None, None, None, (), "infeasible"),
        per.NoDeadbeatCertificate(A, C, 1, np.array([[0.0], [1.0]])),
        per.DeadbeatConflictCertificate(A, C, (1,), 1, 0.0),
        per.PerronCertificate(A, C, 1, np.array([0.0, 1.0]), 0.5, 1.0),
        per.CopositiveCertificate(A, C, np.zeros((1, 2)), np.ones((1, 2)), 0.5),
    ]


def test_every_class_with_a_verify_method_derives_from_the_one_certificate_base():
    """Every certificate of the package (a class whose evidence re-checks with ``verify()``) is a
    :class:`~hybobs_opt.results.Certificate`: found by walking the source, not by a list."""
    import ast
    import importlib
    from pathlib import Path

    package = Path(__file__).resolve().parents[3] / "hybobs_opt"
    found = []
    for path in sorted(package.rglob("*.py")):
        module = ".".join(path.relative_to(package.parent).with_suffix("").parts)
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef) and any(isinstance(b, ast.FunctionDef) and b.name == "verify" for b in node.body):
                found.append((module, node.name))
    assert len(found) >= 13
    for module, name in found:
        cls = getattr(importlib.import_module(module), name)
        assert issubclass(cls, Certificate), f"{module}.{name}"


def test_every_certificate_class_implements_the_protocol():
    from hybobs_opt.lmi.certificates import DualCertificate, InfeasibilityCertificate
    from hybobs_opt.synthesis import periodic_gains as per

    classes = [DualCertificate, InfeasibilityCertificate, per.NoDeadbeatCertificate, per.DeadbeatConflictCertificate,
               per.PerronCertificate, per.CopositiveCertificate]
    for cls in classes:
        assert callable(getattr(cls, "verify", None)), cls
        assert hasattr(cls, "reason") or "reason" in {f.name for f in dataclasses.fields(cls)}, cls
    for cert in _certificates():
        assert isinstance(cert, Certificate), type(cert)
        assert isinstance(cert.reason, str) and cert.reason
        assert isinstance(cert.verify(), bool)


def test_periodic_certificates_verify_on_small_exact_examples():
    from hybobs_opt.synthesis import periodic_gains as per

    # one phase, C = [1 0], A = diag(0.5, 0.5): the second state never shows, span(e2) maps into itself
    A = np.array([[[0.5, 0.0], [0.0, 0.5]]])
    C = np.array([[1.0, 0.0]])
    assert per.NoDeadbeatCertificate(A, C, 1, np.array([[0.0], [1.0]])).verify()
    # positive observer with L = 0: p = 1 decreases by 0.5 per step
    cop = per.CopositiveCertificate(A, C, np.zeros((1, 2)), np.ones((1, 2)), 0.5)
    assert cop.verify() and "0.5" in cop.reason
    assert not per.CopositiveCertificate(A, C, np.zeros((1, 2)), np.ones((1, 2)), 0.25).verify()


def test_owned_results_implement_the_solve_result_protocol():
    from hybobs_opt.geometry.lp import SlackResult, max_slack
    from hybobs_opt.lmi.observer_lmi import LMISolution
    from hybobs_opt.lmi.solve import SolveOutcome

    out = SolveOutcome(Status.OPTIMAL, 0.1, 0.05, 0.02)
    assert isinstance(out, SolveResult) and out.to_dict()["residuals"] == {}
    sol = LMISolution(False, Status.INFEASIBLE, "(8)", 0.0, None, None, outcome=out)
    assert isinstance(sol, SolveResult) and sol.seconds == 0.1 and sol.residuals == {}
    G = np.vstack([np.eye(2), -np.eye(2)])
    res = max_slack(G, np.ones(4), radius_bound=2.0, threshold=0.5)
    assert isinstance(res, SlackResult) and isinstance(res, SolveResult)
    assert res.status is Status.OPTIMAL and res.lower <= 1.0 + 1e-9 and res.upper >= 1.0 - 1e-9
    empty = max_slack(np.array([[0.0, 0.0]]), np.array([-1.0]), radius_bound=2.0, threshold=0.0)
    assert empty.status is Status.INFEASIBLE and empty.residuals == {}
    json.dumps(res.to_dict())


def test_recheck_failed_status_keeps_its_old_text():
    assert Status.RECHECK_FAILED == "optimal (numpy re-check failed)"
    assert "re-check failed" in Status.RECHECK_FAILED and not is_optimal(Status.RECHECK_FAILED)


# ---------------------------------------------------------------------------- row_range
def test_row_range_box_and_equalities():
    from hybobs_opt.errors import ModelError
    from hybobs_opt.geometry.lp import row_range

    A = np.vstack([np.eye(2), -np.eye(2)])
    b = np.array([1.0, 2.0, 3.0, 4.0])  # -3 <= x <= 1, -4 <= y <= 2
    r = row_range(A, b, np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
    np.testing.assert_allclose(r, [[-3.0, 1.0], [-4.0, 2.0], [-7.0, 3.0]], atol=1e-9)
    r = row_range(A, b, np.array([1.0, 1.0]), E=np.array([[1.0, -1.0]]), e=np.array([0.0]))
    np.testing.assert_allclose(r, [[-6.0, 2.0]], atol=1e-9)  # x = y in [-3, 1]
    with pytest.raises(ModelError, match="non-empty"):
        row_range(A, -b, np.eye(2), field="box")
    with pytest.raises(ModelError, match="bounded set"):
        row_range(A[:2], b[:2], np.eye(2))
    with pytest.raises(ModelError, match="columns"):
        row_range(A, b, np.ones((1, 3)))
