"""hybobs_opt: optimization-based state observers for hybrid systems.

Layers (DESIGN.md): ``systems`` and ``examples`` describe plants; ``regions``, ``lmi`` and ``mhe``
pose the design questions as optimisation problems; ``observers`` and ``sim`` run them;
``report`` and :mod:`hybobs_opt.cli` present the results.
"""

from .errors import HybobsError, InfeasibleError, ModelError, SolverError
from .results import Certificate, SolveResult
from .status import Status, is_infeasible, is_optimal, map_status

__version__ = "0.1.0"

__all__ = ["Certificate", "HybobsError", "InfeasibleError", "ModelError", "SolveResult", "SolverError", "Status",
           "__version__", "is_infeasible", "is_optimal", "map_status"]
