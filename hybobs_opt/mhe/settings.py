"""The solve and certification settings of the moving-horizon observer (paper 002, eq. 10).

:class:`MHESettings` gathers the knobs that tune *how* :class:`~hybobs_opt.mhe.MHEObserver`
solves and certifies a window -- solver options, the proximal terms of the MIQP, the warm start's
zero-cost certificate, the budget of the exact prefix search and the uniqueness test behind the
flag ``observable`` -- apart from the keywords that say *what* is estimated (the model, the norm,
the weights and the noise model), which stay on the observer.  One frozen record validates them
once, can be shared by several observers, and ``observer.settings`` states the settings in force
(the observer switches some off where they cannot hold, e.g. the uniqueness test under a noise
bound).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .._validate import as_positive
from ..errors import ModelError
from ..defaults import MHE_CERTIFY_MAX_NODES, MHE_PROX_PASSES, MHE_UNIQUENESS_DELTA
from ..tolerances import MHE_BINARY_PROX_WEIGHT, MHE_PROX_WEIGHT

__all__ = ["MHESettings"]


@dataclass(frozen=True)
class MHESettings:
    """How :class:`~hybobs_opt.mhe.MHEObserver` solves and certifies each window.

    Every value is checked at construction (a bad one is a
    :class:`~hybobs_opt.errors.ModelError` naming the field); the record is frozen, so
    :func:`dataclasses.replace` gives a changed copy, checked again.

    Parameters
    ----------
    solver_options : dict, optional
        Passed to the solver (DAQP settings, HiGHS/CBC/Bonmin options), e.g.
        ``{"iter_limit": 1}`` or ``{"time_limit": 1e-6}``; they override the defaults, which for
        DAQP are ``abs_subopt =`` :data:`~hybobs_opt.tolerances.MHE_ABS_SUBOPT`, ``eps_prox = 0``
        and ``cycle_tol =`` :data:`~hybobs_opt.tolerances.MHE_DAQP_CYCLE_TOL` (1000 iterations
        without progress before DAQP gives up with exit -2, "cycling"; DAQP's own default of 10
        ends the branch-and-bound on degenerate big-M vertices of 4-mode systems at T = 4-5 with
        noisy data).  With the DAQP solver they apply to the uniqueness MIQP too.  Solver
        ``"sequences"`` reads ``{"lp": "highs"}`` (its LPs by HiGHS alone instead of DAQP first),
        ``{"memory_budget": bytes}`` (its prefix tree's budget, default
        :data:`~hybobs_opt.limits.MAX_SEQUENCE_TREE_BYTES`) and ``{"tables": "eager" | "lazy"}``
        (how it builds the tree; default by its size).
        ``None`` (default) is no options; the dict is copied.
    polish : bool
        Norm 2: re-solve the continuous QP of the optimal mode sequence exactly (removes the
        proximal term's bias from the estimate; Notes of :class:`~hybobs_opt.mhe.MHEObserver`).
    prox_weight : float
        Proximal weight ``eps`` of the MIQP's continuous variables (scaled units), default
        :data:`~hybobs_opt.tolerances.MHE_PROX_WEIGHT`.
    binary_prox_weight : float
        Proximal weight of the binaries, default :data:`~hybobs_opt.tolerances.MHE_BINARY_PROX_WEIGHT`.
    zero_cost_certificate : bool
        Accept a warm start of zero cost as the optimum without branch-and-bound (the cost is
        nonnegative).  ``False`` runs the branch-and-bound at every step (the warm start is then
        only its incumbent), e.g. to time it.  An observer whose extension adds a cost term
        switches it off (a linear term can be negative: zero cost proves nothing).
    prox_passes : int
        Largest number of proximal-point passes per window (norm 2), default
        :data:`~hybobs_opt.defaults.MHE_PROX_PASSES`: a pass is repeated, centred at its minimiser, when the
        minimiser moved away from the warm start.
    certify_max_nodes : int
        Norm 2: node QPs the exact prefix search (:mod:`hybobs_opt.mhe.certify`) may solve per
        window when the branch and bound's own certificate does not prove the relative gap
        :data:`~hybobs_opt.tolerances.MHE_CERTIFIED_RTOL`; a window it cannot close is not
        certified (``fallback``).  Solver ``"sequences"``: the LPs its search may solve per
        window (stopped, the window is not certified and its gap is reported).  It also bounds the search for the mode sequences of a
        flagged window's covariance (``arrival_weight="kalman"``).  Default
        :data:`~hybobs_opt.tolerances.MHE_CERTIFY_MAX_NODES`.
    certify_time_budget : float, optional
        Wall-clock seconds a window's certified solve may take (measured from the start of the
        window's solve, every norm): the prefix search (norm 2) stops when it is spent, and an
        optimum certified after it is not used.  Such a window is not certified (``fallback``,
        never ``observable``; the reason says the time budget was hit).  ``None`` (default): no
        limit but ``certify_max_nodes``.  The solver calls themselves are not interrupted, so a
        step can take longer than the budget by one branch and bound or one node QP.
    check_uniqueness : bool
        ``True`` (default): flag ``observable`` only when the window trajectory -- the reported
        state and the window start among it -- is unique (the separated program, Notes of
        :class:`~hybobs_opt.mhe.MHEObserver`).  ``False``: no second program; ``observable``
        then means only "certified optimum", unless the observer's ``analysis`` decides.  Under
        a ``noise_bound`` the radius decides the flag and the observer's effective settings
        have ``False``.
    uniqueness_delta : float
        Separation ``delta`` of an alternative window state from the optimum's at the same step
        (inf-norm, units of the half-widths of ``X``), default
        :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_DELTA`; under a ``noise_bound`` the largest
        radius of an ``observable`` estimate, in the same units.

    Raises
    ------
    ModelError
        A value of the wrong type or out of range, naming its field.

    See Also
    --------
    MHEObserver : Takes them as ``settings``.
    SOLVERS : The solvers by norm.

    Examples
    --------
    >>> from hybobs_opt.mhe import MHESettings
    >>> MHESettings(check_uniqueness=False).to_dict()["check_uniqueness"]
    False
    """

    solver_options: dict = field(default_factory=dict)
    polish: bool = True
    prox_weight: float = MHE_PROX_WEIGHT
    binary_prox_weight: float = MHE_BINARY_PROX_WEIGHT
    zero_cost_certificate: bool = True
    prox_passes: int = MHE_PROX_PASSES
    certify_max_nodes: int = MHE_CERTIFY_MAX_NODES
    certify_time_budget: float | None = None
    check_uniqueness: bool = True
    uniqueness_delta: float = MHE_UNIQUENESS_DELTA

    def __post_init__(self):
        options = self.solver_options
        if options is not None and not isinstance(options, dict):
            raise ModelError("solver_options", "a dict of solver options", type(options).__name__)
        checked = {
            "solver_options": dict(options or {}),
            "polish": bool(self.polish),
            "prox_weight": as_positive(self.prox_weight, "prox_weight", "a positive finite weight"),
            "binary_prox_weight": as_positive(self.binary_prox_weight, "binary_prox_weight", "a positive finite weight"),
            "zero_cost_certificate": bool(self.zero_cost_certificate),
            "prox_passes": _count(self.prox_passes, "prox_passes", "an integer >= 1"),
            "certify_max_nodes": _count(self.certify_max_nodes, "certify_max_nodes",
                                        "an integer >= 1 (node QPs of the prefix search per window)"),
            "certify_time_budget": as_positive(self.certify_time_budget, "certify_time_budget",
                                               "None or a positive finite number of seconds", allow_none=True),
        }
        if not isinstance(self.check_uniqueness, (bool, np.bool_)):
            raise ModelError("check_uniqueness", "True or False", repr(self.check_uniqueness))
        checked["check_uniqueness"] = bool(self.check_uniqueness)
        delta = self.uniqueness_delta
        if not (isinstance(delta, (int, float, np.floating)) and not isinstance(delta, bool)
                and np.isfinite(delta) and delta > 0):
            raise ModelError("uniqueness_delta", "a positive finite separation (units of the half-widths of X)", repr(delta))
        checked["uniqueness_delta"] = float(delta)
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    def to_dict(self) -> dict[str, Any]:
        """The settings as a JSON-ready dict, field by field (``solver_options`` copied).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return asdict(self)


def _count(value, name: str, expected: str) -> int:
    """A positive integer setting (not a bool), or a :class:`~hybobs_opt.errors.ModelError` naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ModelError(name, expected, repr(value))
    return int(value)
