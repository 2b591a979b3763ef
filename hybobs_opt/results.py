"""The two protocols every solver answer and every certificate of the toolbox implements.

:class:`SolveResult` is what one solve returns (an LP, an LMI, a moving-horizon window): its
:class:`~hybobs_opt.status.Status`, the constraint residuals at the returned point, the seconds it
took and a JSON-ready ``to_dict()``.  :class:`Certificate` is the evidence behind a negative (or
positive) verdict: a human-readable ``reason`` and a ``verify()`` that re-checks it in plain numpy,
without calling a solver.  :class:`~hybobs_opt.errors.InfeasibleError` always carries a
certificate whose ``verify()`` is true (DESIGN.md, "One result protocol").

Both are :func:`typing.runtime_checkable`, so ``isinstance(obj, Certificate)`` checks that the
members exist (not their types).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

__all__ = ["SolveResult", "Certificate"]


@runtime_checkable
class SolveResult(Protocol):
    """One solve's answer.

    Attributes
    ----------
    status : Status
        The solver's answer in the one vocabulary (:mod:`hybobs_opt.status`); only
        :func:`~hybobs_opt.status.is_optimal` statuses carry a trusted point.
    seconds : float
        Wall time of the solve.
    residuals : dict of str to float
        Constraint residuals at the returned point (largest violation per constraint family, in
        the units the result documents; empty when no point was returned).
    """

    @property
    def status(self) -> Any: ...

    @property
    def seconds(self) -> float: ...

    @property
    def residuals(self) -> dict[str, float]: ...

    def to_dict(self) -> dict: ...


@runtime_checkable
class Certificate(Protocol):
    """Checkable evidence for a verdict: why it holds, and a numpy re-check of it.

    Attributes
    ----------
    reason : str
        The verdict and its mechanism, stated for the system at hand.
    """

    @property
    def reason(self) -> str: ...

    def verify(self) -> bool:
        """Re-check the evidence in plain numpy (no solver); ``True`` when it holds."""
        ...
