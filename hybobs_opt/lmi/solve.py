"""Running a compiled cvxpy problem through Clarabel: status, timing and the solver-call counters.

Every LMI of the package is a cvxpy problem built once with ``Parameter``s and re-solved here.
The first solve of a problem canonicalises it (cvxpy's DPP compilation); later solves only
substitute the parameters, which is what :data:`COUNTERS` lets the benchmarks check: the share of
wall time in cvxpy compilation versus inside Clarabel.

cvxpy keeps one compiled form per problem object and discards it whenever the problem is solved
with another solver, so a fallback solver is handed a sibling problem (the same objective and
constraint objects, hence the same variables, parameters and dual values) that keeps its own
compiled form: a fallback neither canonicalises the problem again on every rescue nor forces the
next Clarabel solve to.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from ..status import CVXPY_STATUS, Status, map_status
from ..tolerances import LYAPUNOV_MIN_RATIO

#: cvxpy statuses in the one vocabulary (:mod:`hybobs_opt.status`).  No status is an answer by
#: itself: a point is feasible only when it passes the numpy re-check of the problem's own
#: constraints, and infeasibility only with a certificate that passes its re-check.
OPTIMAL = Status.OPTIMAL
INFEASIBLE = Status.INFEASIBLE
SOLVER_ERROR = Status.SOLVER_ERROR

#: Statuses whose point is re-checked (and then used when it passes).  ``optimal_inaccurate`` is
#: among them because these problems are feasibility questions with a norm objective: the
#: solvers stall near the degenerate optimum (Clarabel "AlmostSolved" at a relative gap of 1e-8 on
#: the robot's vertex LMIs) with a point that satisfies the constraints, which the re-check proves
#: or refutes; the objective's optimality is never claimed.
POINT_STATUSES = (Status.OPTIMAL, Status.OPTIMAL_INACCURATE)

SOLVER = "CLARABEL"

_log = logging.getLogger(__name__)


class _ProblemText:
    """The size of a cvxpy problem for a log record, computed only if the record is written."""

    __slots__ = ("problem",)

    def __init__(self, problem: cp.Problem):
        self.problem = problem

    def __str__(self) -> str:
        p = self.problem
        n_vars = sum(int(v.size) for v in p.variables())
        n_psd = sum(1 for c in p.constraints if type(c).__name__ == "PSD")
        return f"{n_vars} variable entries, {len(p.constraints)} constraints ({n_psd} PSD)"


@dataclass
class SolveCounters:
    """Totals over every LMI solve of the process (reset with :meth:`reset`)."""

    calls: int = 0
    seconds: float = 0.0
    compile_seconds: float = 0.0
    solver_seconds: float = 0.0
    first_compile_seconds: float = 0.0
    statuses: dict[str, int] = field(default_factory=dict)
    primary_undecided: int = 0
    undecided: int = 0
    rescued: dict[str, int] = field(default_factory=dict)

    def reset(self) -> None:
        self.calls = 0
        self.seconds = self.compile_seconds = self.solver_seconds = self.first_compile_seconds = 0.0
        self.statuses = {}
        self.primary_undecided = self.undecided = 0
        self.rescued = {}

    def snapshot(self) -> dict:
        other = self.seconds - self.compile_seconds - self.solver_seconds
        total = self.seconds or float("nan")
        return {"calls": self.calls, "seconds": self.seconds, "compile_seconds": self.compile_seconds,
                "first_compile_seconds": self.first_compile_seconds,
                "solver_seconds": self.solver_seconds, "other_seconds": other,
                "compile_share": self.compile_seconds / total, "solver_share": self.solver_seconds / total,
                "other_share": other / total, "statuses": dict(self.statuses),
                "primary_undecided": self.primary_undecided, "undecided": self.undecided, "rescued": dict(self.rescued)}


COUNTERS = SolveCounters()


@dataclass(frozen=True)
class SolveOutcome:
    """Status of one solve and where its time went (seconds); a :class:`~hybobs_opt.results.SolveResult`.

    ``residuals`` holds, per cvxpy constraint class (``"PSD"``, ``"Inequality"``, ``"Equality"``,
    ``"SOC"``...), the largest violation at the solver's point (cvxpy's ``violation()``: the
    most negative eigenvalue for a PSD constraint); it is empty when the solver returned no point.
    """

    status: Status
    seconds: float
    compile_seconds: float
    solver_seconds: float
    message: str = ""
    residuals: dict[str, float] = field(default_factory=dict)
    solver: str = SOLVER
    attempts: tuple[tuple[str, str], ...] = ()

    @property
    def optimal(self) -> bool:
        return self.status == OPTIMAL

    def to_dict(self) -> dict:
        return {"status": self.status, "seconds": self.seconds, "compile_seconds": self.compile_seconds,
                "solver_seconds": self.solver_seconds, "message": self.message, "residuals": dict(self.residuals),
                "solver": self.solver, "attempts": [list(a) for a in self.attempts]}


def cvxpy_status(problem: cp.Problem) -> Status:
    """The status of the last solve of ``problem`` in the one vocabulary.

    cvxpy's strings go through :data:`~hybobs_opt.status.CVXPY_STATUS`; an unsolved problem (status
    ``None``) or a string cvxpy may add later is :attr:`~hybobs_opt.status.Status.UNKNOWN`.  Accept
    the point only when :func:`~hybobs_opt.status.is_optimal` holds (never ``optimal_inaccurate``).
    """
    return map_status(CVXPY_STATUS, problem.status, solver=f"cvxpy/{SOLVER}")


def constraint_residuals(problem: cp.Problem) -> dict[str, float]:
    """Largest violation per constraint class at the current variable values (empty without a point)."""
    out: dict[str, float] = {}
    for con in problem.constraints:
        try:
            v = con.violation()
        except (ValueError, TypeError):  # a variable without a value: the solver returned no point
            return {}
        if v is None:
            return {}
        worst = float(np.max(v)) if np.size(v) else 0.0
        key = type(con).__name__
        out[key] = max(out.get(key, 0.0), worst)
    return out


class LazyResiduals(Mapping):
    """:func:`constraint_residuals` of a solver's point, evaluated on first read.

    cvxpy evaluates each constraint's violation through its expression tree in Python, which
    costs as much as the solve itself for the small LMIs and is read only for reports.  The values
    of the problem's variables and parameters at the solve are kept (copies), so the residuals
    are those of that point even after later solves of the same problem; they are put back for
    the evaluation and the current values restored afterwards.
    """

    def __init__(self, problem: cp.Problem):
        self._problem = problem
        self._values = [(leaf, _copy_value(leaf.value)) for leaf in _leaves(problem)]
        self._result: dict[str, float] | None = None

    def _evaluate(self) -> dict[str, float]:
        if self._result is None:
            current = [(leaf, leaf.value) for leaf, _ in self._values]
            try:
                for leaf, value in self._values:
                    _set_value(leaf, value)
                self._result = constraint_residuals(self._problem)
            finally:
                for leaf, value in current:
                    _set_value(leaf, value)
            self._problem = self._values = None  # the point is no longer needed
        return self._result

    def __getitem__(self, key: str) -> float:
        return self._evaluate()[key]

    def __iter__(self):
        return iter(self._evaluate())

    def __len__(self) -> int:
        return len(self._evaluate())

    def __repr__(self) -> str:
        return repr(self._evaluate())


def _leaves(problem: cp.Problem) -> list:
    """The problem's variables and parameters (listed once per problem object: cvxpy walks the
    expression tree on every call of ``variables()``)."""
    leaves = getattr(problem, "_hybobs_leaves", None)
    if leaves is None:
        leaves = list(problem.variables()) + list(problem.parameters())
        problem._hybobs_leaves = leaves
    return leaves


def _copy_value(value):
    return None if value is None else np.array(value, dtype=float, copy=True)


def _set_value(leaf, value) -> None:
    # stored as cvxpy stores a solver's point (no re-validation: the value was the leaf's own)
    leaf.save_value(value)


#: Conic solvers tried, in order, when Clarabel cannot decide a problem (a status other than
#: ``optimal`` or ``infeasible``: ``solver_error``, ``*_inaccurate``...): Clarabel again with ten
#: times its static KKT regularisation (the vehicle's LMIs at the decay-rate cap fail in the
#: factorisation with the default 1e-8 and are decided with 1e-7), then CVXOPT (a core
#: dependency), an interior-point method with its own scaling (3 steps of iterative refinement: at
#: the degenerate optimum of the norm objective its KKT system turns singular without them), then
#: SCS (a cvxpy dependency), a first-order method run to tight tolerances, only when no solver
#: returned a point at all (a point that failed the re-check lies near the boundary, where SCS's
#: accuracy does not help).  Whatever they return is re-checked like Clarabel's.  Entries are
#: ``(label, cvxpy solver, options, only_without_point)``.
FALLBACK_SOLVERS: tuple[tuple[str, str, dict, bool], ...] = (
    ("CLARABEL(reg=1e-7)", "CLARABEL", {"static_regularization_constant": 1e-7}, False),
    ("CVXOPT", "CVXOPT", {"max_iters": 200, "refinement": 3}, False),
    ("SCS", "SCS", {"eps_abs": 1e-8, "eps_rel": 1e-8, "max_iters": 20_000}, True),
)


def _available(name: str) -> bool:
    return name in _INSTALLED


_INSTALLED = frozenset(cp.installed_solvers())


def solver_problem(problem: cp.Problem, solver: str) -> cp.Problem:
    """The problem object to hand to ``solver``: ``problem`` itself for Clarabel, else its sibling
    for that solver (built on first use and kept on ``problem``).

    The sibling shares the objective and constraint objects, so a solve of it sets the same
    variables' values and constraints' dual values as a solve of ``problem`` would; it only keeps
    its own compiled form (see the module docstring).
    """
    if solver == SOLVER:
        return problem
    siblings = getattr(problem, "_hybobs_siblings", None)
    if siblings is None:
        siblings = problem._hybobs_siblings = {}
    sib = siblings.get(solver)
    if sib is None:
        sib = siblings[solver] = cp.Problem(problem.objective, problem.constraints)
    return sib


def _run_once(problem: cp.Problem, solver: str, options: dict) -> tuple[Status, str]:
    """One solve of ``problem`` (the object given, see :func:`solver_problem`) by ``solver``."""
    with warnings.catch_warnings():
        # "Solution may be inaccurate" is carried by the status, which callers check.
        warnings.simplefilter("ignore", UserWarning)
        try:
            problem.solve(solver=solver, **options)
        except (cp.error.SolverError, ArithmeticError, ValueError, RuntimeError) as exc:
            # RuntimeError: the solver's own crash (a CVXOPT failure)
            return SOLVER_ERROR, f"{solver}: {type(exc).__name__}: {exc}"
        except BaseException as exc:
            # a Rust panic inside Clarabel ("Eigval error" in a PSD cone's step length) surfaces as
            # pyo3's PanicException, which derives from BaseException, not Exception
            if type(exc).__name__ != "PanicException":
                raise
            # the panicked solver object stays in cvxpy's warm-start cache and panics on every
            # later update ("Option::unwrap() on a None value"): drop it so the next solve starts fresh
            getattr(problem, "_solver_cache", {}).pop(solver, None)
            return SOLVER_ERROR, f"{solver}: Rust panic: {exc}"
    status = map_status(CVXPY_STATUS, problem.status, solver=f"cvxpy/{solver}")
    if status in POINT_STATUSES and not _point_is_finite(problem):
        return SOLVER_ERROR, f"{solver}: status {status} with a missing or non-finite point"
    return status, ""


def _point_is_finite(problem: cp.Problem) -> bool:
    """Every variable of ``problem`` has a value and every entry is finite."""
    for v in _leaves(problem):
        if not isinstance(v, cp.Variable):
            continue
        val = v.value
        if val is None or not np.all(np.isfinite(np.asarray(val, dtype=float))):
            return False
    return True


def solve_checked(problem: cp.Problem, read, solve=None):
    """:func:`solve_problem` with ``read()`` (the caller's point, re-checked) as the chain's ``accept``.

    Returns ``(outcome, point)``: ``point`` is the re-checked point that ended the chain (its
    check is the answer's, so it is not repeated), or ``None`` when no point passed.  ``solve``
    replaces :func:`solve_problem` (the caller's module-level name, so that a test substituting it
    there reaches this call).
    """
    accepted = []

    def accept() -> bool:
        point = read()
        if point.feasible:
            accepted.append(point)
        return point.feasible

    out = (solve or solve_problem)(problem, accept=accept)
    return out, (accepted[-1] if accepted and out.status in POINT_STATUSES else None)


def checked_lyapunov(P, what: str, solver: str = SOLVER) -> np.ndarray:
    """The symmetric part of a Lyapunov matrix returned by ``solver`` for ``what``, once checked in
    numpy: finite and positive definite (smallest eigenvalue above
    :data:`~hybobs_opt.tolerances.LYAPUNOV_MIN_RATIO` times
    the largest).

    Raises
    ------
    SolverError
        ``P`` is missing, not finite or not positive definite: the solver's "optimal" answer is not one.
    """
    from ..errors import SolverError

    if P is None or not np.all(np.isfinite(np.asarray(P, dtype=float))):
        raise SolverError(what, solver, "optimal, but the Lyapunov matrix P is missing or not finite",
                          "re-run; if it persists, rescale the model or try another solver")
    P = np.asarray(P, dtype=float)
    P = 0.5 * (P + P.T)
    w = np.linalg.eigvalsh(P)
    if not (w[-1] > 0 and w[0] > LYAPUNOV_MIN_RATIO * w[-1]):
        raise SolverError(what, solver, f"optimal, but P is not positive definite (eigenvalues {w[0]:.3g}..{w[-1]:.3g})",
                          "re-run; if it persists, rescale the model or try another solver")
    return P



_ON_SOLVE: ContextVar[Callable[[int], None] | None] = ContextVar("hybobs_opt_on_lmi_solve", default=None)


@contextmanager
def counting_solves(callback: Callable[[int], None] | None) -> Iterator[None]:
    """Call ``callback(n)`` after each :func:`solve_problem` in the block (``n``: solves so far in it).

    The progress of work whose number of solves is not known in advance (the region growing and
    dwell-time search of ``hybobs synth``).
    """
    if callback is None:
        yield
        return
    count = [0]

    def tick(_: int) -> None:
        count[0] += 1
        callback(count[0])

    token = _ON_SOLVE.set(tick)
    try:
        yield
    finally:
        _ON_SOLVE.reset(token)


def solve_problem(problem: cp.Problem, *, fallback: bool = True, accept=None) -> SolveOutcome:
    """Solve ``problem`` with Clarabel, then with :data:`FALLBACK_SOLVERS` while it is undecided.

    ``accept()``, when given, is asked after every solve that returned a point (``optimal`` or
    ``optimal_inaccurate``) whether it passes the caller's re-check: the chain stops at the first
    point that does, and goes on past one that does not.

    A crash becomes status :data:`SOLVER_ERROR`, never an exception.  The outcome names the
    solver whose answer it carries and every attempt; :data:`COUNTERS` counts Clarabel's own
    undecided solves (``primary_undecided``, an inaccurate point that passed ``accept`` not
    included) and those no solver decided (``undecided``).
    """
    first = problem._cache.param_prog is None if hasattr(problem, "_cache") else False
    t0 = time.perf_counter()
    attempts: list[tuple[str, str]] = []
    messages = []
    compile_s = solver_s = 0.0
    chain = [(SOLVER, SOLVER, {}, False)] + ([e for e in FALLBACK_SOLVERS if _available(e[1])] if fallback else [])
    status, used, accepted, had_point = SOLVER_ERROR, SOLVER, False, False
    for label, name, options, only_without_point in chain:
        if only_without_point and had_point:
            # a point near the boundary failed the re-check: a first-order method will not do better
            break
        target = solver_problem(problem, name)
        status, message = _run_once(target, name, options)
        used = label
        attempts.append((label, str(status)))
        if message:
            messages.append(message)
        compile_s += float(getattr(target, "compilation_time", 0.0) or 0.0)
        stats = getattr(target, "solver_stats", None)
        if stats is not None and status != SOLVER_ERROR:
            solver_s += float(getattr(stats, "solve_time", 0.0) or 0.0)
        if status in POINT_STATUSES and accept is not None:
            had_point = True
            if accept():
                accepted = True
                break
            continue  # a point that fails the caller's re-check: the next solver may return a better one
        if status in (OPTIMAL, INFEASIBLE):
            break
    seconds = time.perf_counter() - t0
    COUNTERS.calls += 1
    COUNTERS.seconds += seconds
    COUNTERS.compile_seconds += compile_s
    COUNTERS.solver_seconds += solver_s
    if first:
        COUNTERS.first_compile_seconds += compile_s
    COUNTERS.statuses[status] = COUNTERS.statuses.get(status, 0) + 1
    if len(attempts) > 1:
        COUNTERS.primary_undecided += 1
        if status == INFEASIBLE or accepted or (status == OPTIMAL and accept is None):
            COUNTERS.rescued[used] = COUNTERS.rescued.get(used, 0) + 1
    if not (status == INFEASIBLE or accepted or (status == OPTIMAL and accept is None)):
        COUNTERS.undecided += 1
    residuals = LazyResiduals(problem) if status in (OPTIMAL, Status.OPTIMAL_INACCURATE) else {}
    _log.debug("LMI solve: problem of %s; solver %s, status %s, %.3g s (compile %.3g s, solver %.3g s)",
               _ProblemText(problem), used, status, seconds, compile_s, solver_s)
    if len(attempts) > 1:
        _log.info("LMI solve not decided by %s alone: attempts %s, answer %s (%s) after %.3g s", SOLVER,
                  ", ".join(f"{label}: {st}" for label, st in attempts), status, used, seconds)
    listener = _ON_SOLVE.get()
    if listener is not None:
        listener(COUNTERS.calls)
    return SolveOutcome(status, seconds, compile_s, solver_s, "; ".join(messages), residuals, used, tuple(attempts))
