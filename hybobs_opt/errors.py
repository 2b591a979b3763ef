"""The one exception hierarchy of hybobs_opt (see DESIGN.md, "Conventions").

``HybobsError`` is the base.  ``ModelError`` is bad input (it is also a ``ValueError`` so generic
callers can catch it the usual way), ``InfeasibleError`` carries the certificate that proves an
optimisation problem has no solution, and ``SolverError`` means a solver crashed, hit a limit or
returned a point it could not certify: it names the problem, the solver and what to try;
``BuildError`` means generated code did not compile or run.
"""

from __future__ import annotations

from typing import Any


class HybobsError(Exception):
    """Base class of every error raised on purpose by hybobs_opt.

    Parameters
    ----------
    *args
        The message (and any further arguments), as for :class:`Exception`.
    **kwargs
        None accepted (:class:`Exception` takes no keyword arguments).

    See Also
    --------
    ModelError, SolverError, InfeasibleError, BuildError : the errors raised on purpose.

    Examples
    --------
    Catch every error the toolbox raises on purpose (and nothing else) with one clause:

    >>> from hybobs_opt import HybobsError, ModelError
    >>> try:
    ...     raise ModelError("horizon", "an integer >= 1", "0")
    ... except HybobsError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelError - horizon: expected an integer >= 1, got 0
    """


class ModelError(HybobsError, ValueError):
    """Invalid model or input data.

    Parameters
    ----------
    field
        Name of the offending field or argument (e.g. ``"modes[2].A"``).
    expected
        What was expected there (shape, range, property).
    got
        Optional description of what was received.

    See Also
    --------
    HybobsError : the base class.

    Examples
    --------
    The message names the field, what was expected and what was given; the parts are attributes:

    >>> from hybobs_opt import ModelError
    >>> error = ModelError("horizon", "an integer >= 1", "0")
    >>> str(error)
    'horizon: expected an integer >= 1, got 0'
    >>> error.field, error.expected, error.got
    ('horizon', 'an integer >= 1', '0')
    """

    def __init__(self, field: str, expected: str, got: str | None = None):
        self.field = field
        self.expected = expected
        self.got = got
        message = f"{field}: expected {expected}"
        if got is not None:
            message += f", got {got}"
        super().__init__(message)

    def __reduce__(self):  # rebuilt from its fields in another process (a worker's error reaches the caller)
        return type(self), (self.field, self.expected, self.got)


class InfeasibleError(HybobsError):
    """An optimisation problem is infeasible; ``certificate`` proves it (``certificate.verify()``).

    Parameters
    ----------
    problem : str
        Name of the problem (e.g. ``"positive deadbeat observer (16)"``).
    certificate : object, optional
        The proof of infeasibility (with ``verify()``), or ``None``.
    detail : str, optional
        Explanation appended to the message.

    See Also
    --------
    hybobs_opt.Certificate : the evidence ``certificate`` holds.
    SolverError : a failure without a proof.

    Examples
    --------
    The error carries the certificate that proves the infeasibility; here the Farkas certificate
    of an infeasible LP:

    >>> import numpy as np
    >>> from hybobs_opt import InfeasibleError
    >>> from hybobs_opt.geometry import solve_lp
    >>> certificate = solve_lp(np.array([1.0]), np.array([[1.0], [-1.0]]), np.array([-1.0, 0.0])).certificate
    >>> error = InfeasibleError("LP x <= -1, x >= 0", certificate)
    >>> error.certificate.verify()
    True
    """

    def __init__(self, problem: str, certificate: Any = None, detail: str = ""):
        self.problem = problem
        self.certificate = certificate
        self.detail = detail
        message = f"{problem} is infeasible"
        if detail:
            message += f": {detail}"
        super().__init__(message)

    def __reduce__(self):
        return type(self), (self.problem, self.certificate, self.detail)


class SolverError(HybobsError):
    """A solver failed, hit a limit, or returned an answer it could not certify.

    Parameters
    ----------
    problem : str
        Name of the problem.
    solver : str
        The solver's name.
    status : str
        The solver's status.
    hint : str, optional
        What to try, appended to the message.

    See Also
    --------
    InfeasibleError : a proven infeasibility, not a failure.
    hybobs_opt.Status : the status vocabulary of ``status``.

    Examples
    --------
    >>> from hybobs_opt import SolverError
    >>> error = SolverError("LP", "highs", "time_limit", "raise the limit")
    >>> str(error)
    "LP: solver highs returned status 'time_limit'; try: raise the limit"
    >>> error.solver, error.status
    ('highs', 'time_limit')
    """

    def __init__(self, problem: str, solver: str, status: str, hint: str = ""):
        self.problem = problem
        self.solver = solver
        self.status = status
        self.hint = hint
        message = f"{problem}: solver {solver} returned status {status!r}"
        if hint:
            message += f"; try: {hint}"
        super().__init__(message)

    def __reduce__(self):
        return type(self), (self.problem, self.solver, self.status, self.hint)


class BuildError(HybobsError):
    """Generated code that does not build or run (the C export's check).

    Parameters
    ----------
    what : str
        What was built (e.g. ``"the exported C of 'powertrain3' at T = 3"``).
    stage : str
        ``"compile"`` or ``"run"``.
    output : str
        The compiler's or the program's messages (the first lines).

    See Also
    --------
    hybobs_opt.observers.export_lookup_c : the C export whose check raises it.

    Examples
    --------
    >>> from hybobs_opt import BuildError
    >>> error = BuildError("the C export", "compile", "x.c:1: error")
    >>> str(error)
    'the C export: the compile step failed: x.c:1: error'
    >>> error.stage
    'compile'
    """

    def __init__(self, what: str, stage: str, output: str = ""):
        self.what, self.stage, self.output = what, stage, output
        first = " | ".join(line.strip() for line in output.strip().splitlines()[:3])
        message = f"{what}: the {stage} step failed" + (f": {first}" if first else "")
        super().__init__(message)

    def __reduce__(self):
        return type(self), (self.what, self.stage, self.output)
