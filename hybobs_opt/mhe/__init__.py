"""Moving-horizon estimation posed as MIQP / MILP (paper 002, eq. 10; Bemporad, Ferrari-Trecate, Morari 2000).

``encode_mld`` derives the mixed-logical-dynamical / big-M encoding of a PWA system with every
big-M constant computed by LPs; ``MHEObserver`` builds the problem once and re-solves it each
step (2-norm: MIQP by DAQP's branch-and-bound; 1-/inf-norm: MILP by HiGHS) and
``MHEObserver.solve_window`` returns a typed :class:`WindowResult`.  The package implements the
runtime contract of :mod:`hybobs_opt.contract` and sits below the runtime-observer package.
"""

from .mld import MLDEncoding, big_m_constants, encode_mld
from .observer import NORMS, SOLVERS, MHEObserver
from .result import WindowResult
from .uniqueness import SeparatedProgram

__all__ = ["MHEObserver", "MLDEncoding", "NORMS", "SOLVERS", "SeparatedProgram", "WindowResult", "big_m_constants",
           "encode_mld"]
