"""The typed answer of one moving-horizon window (paper 002, eq. 10).

:class:`WindowResult` is what :meth:`~hybobs_opt.mhe.MHEObserver.solve_window` returns: a frozen
record implementing the result protocol of :mod:`hybobs_opt.results` (``status``, ``residuals``,
``seconds``, ``to_dict()``).  It also reads like the dict it replaces (``result["status"]``,
``result.get("alternative")``, ``"reason" in result``), with exactly the keys that dict had, so
scripts written against the dict keep working.

``Estimate.info`` of the observer stays a plain dict, built by :meth:`WindowResult.to_dict` plus
the observer's own keys (``certified_optimum``, ``uniqueness``, ``alternative``, ``reason``,
``analysis_label``): an observer's ``info`` is a dict by the runtime contract
(:class:`~hybobs_opt.contract.Estimate`), and callers test ``isinstance(est.info, dict)``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from ..status import Status

__all__ = ["WindowResult"]

#: ``to_dict()`` order of the optional fields (the order the old dict was built in); a field
#: that is ``None`` is absent from the dict, as the key was.
_KEYS = ("status", "solver", "solved_by", "polished", "x_start", "states", "modes", "w", "cost", "gap_bound",
         "verified_violation", "passes", "reason")


@dataclass(frozen=True, eq=False)
class WindowResult(Mapping):
    """Answer of one window of eq. (10): status, trajectory and how it was certified.

    Parameters
    ----------
    status : Status
        ``OPTIMAL`` (a certified global optimum: see the module docstring of
        :mod:`hybobs_opt.mhe.observer`), ``INFEASIBLE`` (the solver proved that no model
        trajectory in ``X`` fits the window's inputs) or ``NOT_CERTIFIED`` (``reason`` says why).
    solver : str or None
        The solver's name (``None`` when no solver was asked, e.g. an input outside ``U``).
    solved_by : str or None
        ``"warm start"``, ``"branch-and-bound"`` or ``"branch-and-bound (incumbent)"``.
    polished : bool or None
        Whether the continuous part was re-solved exactly for the optimal mode sequence.
    x_start : (n,) array or None
        Window-start state ``x(t-T+1)``.
    states : (T, n) array or None
        The model trajectory from ``x_start`` with ``modes`` and ``w``.
    modes : (T,) int array or None
    w : (T - 1, n) array or None
        Disturbances (zeros without a disturbance weight).
    cost : float or None
        Cost of eq. (10) at the trajectory (original units, recomputed in numpy).
    gap_bound : float or None
        Upper bound on ``cost - optimum``.
    verified_violation : float or None
        Largest MLD row violation of the solver's point (branch-and-bound answers only).
    passes : int or None
        Proximal-point passes (norm 2).
    reason : str or None
        Why the window is not certified.
    solver_detail : dict
        The solver's raw answer (``status``, ``nodes``, ...), shown as ``solver_<key>``.
    uniqueness : dict or None
        The uniqueness test of the flag ``observable`` (``solve_window(..., uniqueness=True)``).
    alternative : dict or None
        Another window-start state ``delta`` away whose cost is within ``epsilon`` of the optimum.
    seconds : float
        Wall time of the window's solve.
    residual_source : callable, optional
        ``residual_source() -> dict`` giving ``residuals`` (called once, on first access).

    Attributes
    ----------
    residuals : dict of str to float
        Constraint residuals at the returned point: ``"mld_rows"``, the largest violation of the
        (row-normalised) MLD rows, bounds and integrality of the window at the trajectory (empty
        when no point is returned).  Computed in numpy on first access (the observer's loop never
        reads them: every accepted point was verified before it was accepted).

    See Also
    --------
    MHEObserver.solve_window : Returns one.
    UniquenessOutcome : The outcome of its uniqueness test.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> res = MHEObserver(plant, 3).solve_window(U[:3], truth.y[:3], uniqueness=True)
    >>> res.status, res.optimal, res.solver
    ('optimal', True, 'daqp')
    >>> res.states.shape, res.modes
    ((3, 3), array([2, 2, 2]))
    >>> bool(np.allclose(res.states, truth.x[:3], atol=1e-6)), res.uniqueness["status"]
    (True, <UniquenessOutcome.UNIQUE: 'unique'>)
    """

    status: Status
    solver: str | None = None
    solved_by: str | None = None
    polished: bool | None = None
    x_start: np.ndarray | None = None
    states: np.ndarray | None = None
    modes: np.ndarray | None = None
    w: np.ndarray | None = None
    cost: float | None = None
    gap_bound: float | None = None
    verified_violation: float | None = None
    passes: int | None = None
    reason: str | None = None
    solver_detail: dict = field(default_factory=dict)
    uniqueness: dict | None = None
    alternative: dict | None = None
    seconds: float = float("nan")
    residual_source: Callable[[], dict] | None = field(default=None, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "status", Status(self.status))

    @property
    def residuals(self) -> dict[str, float]:
        cached = self.__dict__.get("_residuals")
        if cached is None:
            cached = {} if self.residual_source is None else dict(self.residual_source())
            object.__setattr__(self, "_residuals", cached)
        return cached

    @property
    def optimal(self) -> bool:
        """Whether the window has a certified optimum."""
        return self.status == Status.OPTIMAL

    def replace(self, **changes: Any) -> WindowResult:
        """A copy with some fields changed (the record is frozen).

        :func:`dataclasses.replace` re-runs ``__init__``; this copies the fields (a few
        microseconds less per window on the observer's fast path).

        Parameters
        ----------
        **changes
            New values by field name.

        Returns
        -------
        WindowResult
            A copy with some fields changed (the record is frozen).

        Raises
        ------
        TypeError
            If a name is not a field of :class:`WindowResult`.
        """
        unknown = set(changes) - _FIELDS
        if unknown:
            raise TypeError(f"WindowResult has no field(s) {sorted(unknown)}")
        if "status" in changes:
            changes["status"] = Status(changes["status"])
        new = object.__new__(WindowResult)
        state = {k: v for k, v in self.__dict__.items() if k != "_residuals"}
        state.update(changes)
        new.__dict__.update(state)
        return new

    def to_dict(self) -> dict[str, Any]:
        """The dict the window used to return: the same keys, in the same order, the same values.

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        out: dict[str, Any] = {}
        for key in _KEYS:
            value = getattr(self, key)
            if value is not None:
                out[key] = value
            if key == "solved_by":
                # the solver's details came right after the solver's name and method
                out.update({f"solver_{k}": v for k, v in self.solver_detail.items()})
        if self.uniqueness is not None:
            out["uniqueness"] = self.uniqueness
        if self.alternative is not None:
            out["alternative"] = self.alternative
        return out

    def to_pandas(self, state_names: Sequence[str] = ()) -> Any:
        """The window's trajectory as a pandas DataFrame, one row per sample of the window.

        Parameters
        ----------
        state_names : sequence of str, optional
            Names of the states (``system.state_names``); default ``x1, x2, ...``.

        Returns
        -------
        pandas.DataFrame
            Columns, in order: ``k`` (sample of the window, ``0`` is the window start
            ``x(t-T+1)``), one per state (the trajectory ``states``), ``mode`` (``modes``) and
            ``w_<state>`` per state (the disturbance ``w`` from sample ``k`` to ``k + 1``;
            ``nan`` on the last row, which has none); a default ``RangeIndex``.

        Raises
        ------
        ModelError
            The window returned no trajectory (field ``states``; ``reason`` says why), the names
            do not fit, or pandas is not installed (the ``interop`` extra).

        See Also
        --------
        WindowResult.to_dict : The scalar fields and arrays as a dict.

        Examples
        --------
        >>> import numpy as np
        >>> from hybobs_opt.mhe.result import WindowResult
        >>> res = WindowResult("optimal", states=np.array([[1.0], [0.5]]), modes=np.array([0, 1]),
        ...                    w=np.array([[0.0]]))
        >>> res.to_pandas(("x",)).to_dict("list")
        {'k': [0, 1], 'x': [1.0, 0.5], 'mode': [0, 1], 'w_x': [0.0, nan]}
        """
        from .._frames import frame
        from ..errors import ModelError

        if self.states is None:
            raise ModelError("states", "a window that returned a trajectory", f"none (status {self.status}"
                             + (f": {self.reason})" if self.reason else ")"))
        X = np.asarray(self.states, dtype=float)
        T, n = X.shape
        names = list(state_names) or [f"x{i + 1}" for i in range(n)]
        if len(names) != n:
            raise ModelError("state_names", f"{n} names (the window's states)", f"{len(names)}")
        W = np.full((T, n), np.nan)
        if self.w is not None:
            w = np.asarray(self.w, dtype=float).reshape(-1, n)
            W[: w.shape[0]] = w
        modes = np.full(T, -1) if self.modes is None else np.asarray(self.modes, dtype=int)
        return frame([("k", np.arange(T)), *zip(names, X.T), ("mode", modes),
                      *((f"w_{nm}", W[:, i]) for i, nm in enumerate(names))], "WindowResult")

    # ------------------------------------------------------------------ read access as a dict
    def __getitem__(self, key: str) -> Any:
        return self.to_dict()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())

    def __contains__(self, key: object) -> bool:
        return key in self.to_dict()

    def __repr__(self) -> str:
        shown = ", ".join(f"{f.name}={getattr(self, f.name)!r}" for f in fields(self)
                          if f.name in ("status", "solver", "solved_by", "cost", "gap_bound", "reason")
                          and getattr(self, f.name) is not None)
        return f"WindowResult({shown})"


_FIELDS = frozenset(f.name for f in fields(WindowResult))
