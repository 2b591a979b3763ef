"""Moving-horizon observers posed as MIQP / MILP (paper 002, eq. 10; Bemporad, Ferrari-Trecate, Morari 2000).

``encode_mld`` derives the mixed-logical-dynamical / big-M encoding of a PWA system with every
big-M constant computed by LPs; ``MHEObserver`` builds the problem once and re-solves it each
step (2-norm: MIQP by DAQP's branch-and-bound; 1-/inf-norm: MILP by HiGHS).
"""

from .miqp import MHEObserver
from .mld import MLDEncoding, big_m_constants, encode_mld

__all__ = ["MHEObserver", "MLDEncoding", "big_m_constants", "encode_mld"]
