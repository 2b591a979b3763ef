"""Old home of the moving-horizon observer of eq. (10), paper 002 (kept for imports).

The 1,700-line module was split along its own section banners (issue 13):

==============================  ===============================================================
module                          holds
==============================  ===============================================================
:mod:`hybobs_opt.mhe.observer`  :class:`MHEObserver` (the runtime object), ``NORMS``,
                                ``SOLVERS``, ``DEFAULT_PROX_PASSES``
:mod:`~hybobs_opt.mhe.result`   :class:`~hybobs_opt.mhe.result.WindowResult`, the typed answer
                                of :meth:`MHEObserver.solve_window`
:mod:`~hybobs_opt.mhe.window`   the model side of a window (dynamics, cost, one mode sequence)
:mod:`~hybobs_opt.mhe.residual` the weights and the stacked residual
:mod:`~hybobs_opt.mhe.uniqueness`  the separated program of the flag ``observable``
:mod:`~hybobs_opt.mhe.backends` one module per solver family behind one signature
==============================  ===============================================================

Every name this module had is re-exported here under its old name (``_DaqpBackend`` is
:class:`~hybobs_opt.mhe.backends.daqp_backend.DaqpBackend`, ``_Outcome`` is
:class:`~hybobs_opt.mhe.backends.base.BackendOutcome`, ...).  These are references, not the
modules the code reads its globals from: to patch a constant or a class, patch the module that
defines it.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import solve_triangular

from ..contract import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP, Estimate, Observer
from ..errors import ModelError, SolverError
from ..status import DAQP_EXIT_FLAGS as _DAQP_EXIT_FLAGS
from ..systems.pwa import PWASystem
from ..tolerances import (
    MEMBERSHIP_RTOL,
    MHE_ABS_SUBOPT,
    MHE_BINARY_PROX_WEIGHT,
    MHE_DAQP_CYCLE_TOL,
    MHE_FEASIBILITY_TOL,
    MHE_INTEGRALITY_TOL,
    MHE_MILP_FEASIBILITY_TOL,
    MHE_POLISH_SKIP_TOL,
    MHE_PROX_WEIGHT,
    MHE_UNIQUENESS_COST_ATOL,
    MHE_UNIQUENESS_COST_RTOL,
    MHE_UNIQUENESS_DELTA,
    MHE_UNIQUENESS_PROX_WEIGHT,
    MHE_ZERO_COST_RTOL,
)
from .backends.base import BackendOutcome as _Outcome
from .backends.base import _NULL, _Null
from .backends.casadi_backend import BonminBackend as _BonminBackend
from .backends.casadi_backend import CasadiDaqpBackend as _CasadiDaqpBackend
from .backends.casadi_backend import CasadiMilpBackend as _MilpBackend
from .backends.daqp_backend import DAQP_INF as _DAQP_INF
from .backends.daqp_backend import DaqpBackend as _DaqpBackend
from .backends.highs_backend import HighspyBackend as _HighspyBackend
from .mld import BigMConstants, MLDEncoding, encode_mld
from .observer import DEFAULT_PROX_PASSES, NORMS, SOLVERS, MHEObserver, _same_pwa
from .residual import StackedResidual as _Residual
from .residual import stacked_residual as _residual
from .residual import weight_matrix as _weight
from .result import WindowResult
from .uniqueness import UNIQUENESS_MAX_SOLVES

#: DAQP's exit flags under their old names (:data:`hybobs_opt.status.DAQP_EXIT_FLAGS`).
_DAQP_OPTIMAL = _DAQP_EXIT_FLAGS["OPTIMAL"]
_DAQP_INFEASIBLE = _DAQP_EXIT_FLAGS["INFEASIBLE"]
_DAQP_CYCLING = _DAQP_EXIT_FLAGS["CYCLE"]
_DAQP_ITERLIMIT = _DAQP_EXIT_FLAGS["ITERLIMIT"]

#: Every name the old module had (so that ``from hybobs_opt.mhe.miqp import *`` and each name work).
__all__ = ["sys", "time", "dataclass", "Any", "np", "solve_triangular", "ModelError", "SolverError",
           "FALLBACK", "OBSERVABLE", "UNOBSERVABLE", "WARMING_UP", "Estimate", "Observer", "PWASystem",
           "MEMBERSHIP_RTOL", "MHE_ABS_SUBOPT", "MHE_BINARY_PROX_WEIGHT", "MHE_DAQP_CYCLE_TOL",
           "MHE_FEASIBILITY_TOL", "MHE_INTEGRALITY_TOL", "MHE_MILP_FEASIBILITY_TOL", "MHE_POLISH_SKIP_TOL",
           "MHE_PROX_WEIGHT", "MHE_UNIQUENESS_COST_ATOL", "MHE_UNIQUENESS_COST_RTOL", "MHE_UNIQUENESS_DELTA",
           "MHE_UNIQUENESS_PROX_WEIGHT", "MHE_ZERO_COST_RTOL", "BigMConstants", "MLDEncoding", "encode_mld",
           "NORMS", "SOLVERS", "DEFAULT_PROX_PASSES", "UNIQUENESS_MAX_SOLVES", "_DAQP_INF", "_DAQP_OPTIMAL",
           "_DAQP_INFEASIBLE", "_DAQP_CYCLING", "_DAQP_ITERLIMIT", "_Null", "_NULL", "_Outcome", "_weight",
           "_Residual", "_residual", "_DaqpBackend", "_CasadiDaqpBackend", "_BonminBackend", "_HighspyBackend",
           "_MilpBackend", "MHEObserver", "_same_pwa", "WindowResult"]
