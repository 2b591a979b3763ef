"""What every solver answer and every certificate of the toolbox is.

:class:`SolveResult` is what one solve returns (an LP, an LMI, a moving-horizon window): its
:class:`~hybobs_opt.status.Status`, the constraint residuals at the returned point, the seconds it
took and a JSON-ready ``to_dict()``.  :class:`Certificate` is the evidence behind a negative (or
positive) verdict: a human-readable ``reason`` and a ``verify()`` that re-checks it in plain numpy,
without calling a solver.  :class:`~hybobs_opt.errors.InfeasibleError` always carries a
certificate whose ``verify()`` is true (DESIGN.md, "One result protocol").

:class:`SolveResult` is a :func:`typing.runtime_checkable` protocol (``isinstance`` checks that the
members exist); :class:`Certificate` is the base class every certificate derives from.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
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

    See Also
    --------
    hybobs_opt.geometry.LPResult : the LP answer, one implementation of this protocol.
    hybobs_opt.Status : the vocabulary of ``status``.

    Examples
    --------
    Every solver answer of the toolbox is a ``SolveResult``: a status, the residuals at the
    returned point and the wall time.

    >>> import numpy as np
    >>> from hybobs_opt import SolveResult, is_optimal
    >>> from hybobs_opt.geometry import solve_lp
    >>> result = solve_lp(np.array([1.0, 1.0]), bounds=[(1, 2), (0, 3)])
    >>> isinstance(result, SolveResult), is_optimal(result.status)
    (True, True)
    >>> result.residuals
    {'bounds': 0.0}
    >>> sorted(result.to_dict())
    ['certificate', 'objective', 'residuals', 'seconds', 'solver', 'status', 'x']
    """

    @property
    def status(self) -> Any: ...

    @property
    def seconds(self) -> float: ...

    @property
    def residuals(self) -> dict[str, float]: ...

    def to_dict(self) -> dict:
        """JSON-ready record of the answer.

        Returns
        -------
        dict
            At least ``status``, ``seconds`` and ``residuals``; the implementations add their own fields.
        """
        ...


class Certificate(ABC):
    """Checkable evidence for a verdict: why it holds, and a numpy re-check of it.

    The one base class of every certificate of the toolbox (LP and Farkas certificates, the LMI
    duals and infeasibility certificates, the polytopic and impossibility certificates, the
    detection-delay certificate of paper 000, the deadbeat and positivity certificates of paper 003,
    the arrival prior of the moving-horizon observer).  A subclass -- a frozen dataclass of the
    evidence -- provides ``reason`` (a field or a property) and :meth:`verify`; :meth:`to_dict`
    gives the JSON-ready summary (subclasses add their own fields).

    Attributes
    ----------
    reason : str
        The verdict and its mechanism, stated for the system at hand.

    See Also
    --------
    hybobs_opt.InfeasibleError : carries a certificate that verifies.
    hybobs_opt.geometry.solve_lp : an infeasible LP's answer holds a Farkas certificate.

    Examples
    --------
    An infeasible LP (``x <= -1`` and ``x >= 0``) answers with a Farkas certificate, which re-checks
    itself in numpy:

    >>> import numpy as np
    >>> from hybobs_opt import Certificate
    >>> from hybobs_opt.geometry import solve_lp
    >>> result = solve_lp(np.array([1.0]), np.array([[1.0], [-1.0]]), np.array([-1.0, 0.0]))
    >>> result.status.value
    'infeasible'
    >>> certificate = result.certificate
    >>> isinstance(certificate, Certificate), certificate.verify()
    (True, True)
    >>> print(certificate.reason)
    LP is infeasible: non-negative multipliers combine its rows into 0 <= b'y + e'w < 0
    """

    __slots__ = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if not any("reason" in vars(k) or "reason" in vars(k).get("__annotations__", {}) for k in cls.__mro__
                   if k is not Certificate):
            raise TypeError(f"certificate class {cls.__name__} defines no 'reason' (a field or a property)")

    @abstractmethod
    def verify(self) -> bool:
        """Re-check the evidence in plain numpy (no solver); ``True`` when it holds.

        Returns
        -------
        bool
            ``True`` when the evidence holds in numpy.
        """

    def to_dict(self) -> dict:
        """JSON-ready summary: the class, the reason and whether :meth:`verify` holds.

        Returns
        -------
        dict
            ``certificate`` (the class name), ``reason`` and ``verified``.
        """
        return {"certificate": type(self).__name__, "reason": str(self.reason), "verified": bool(self.verify())}
