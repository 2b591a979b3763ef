"""Moving-horizon estimation posed as MIQP / MILP (paper 002, eq. 10; Bemporad, Ferrari-Trecate, Morari 2000).

``encode_mld`` derives the mixed-logical-dynamical / big-M encoding of a PWA system with every
big-M constant computed by LPs; ``MHEObserver`` builds the problem once and re-solves it each
step (2-norm: MIQP by DAQP's branch-and-bound; 1-/inf-norm: MILP by HiGHS), tuned by one
:class:`MHESettings` (solver options, proximal terms, certification budget, uniqueness test), and
``MHEObserver.solve_window`` returns a typed :class:`WindowResult`.  A 2-norm window whose
branch and bound does not prove the relative gap is certified (or its optimum found) by the exact
prefix search :func:`search_sequences` (:mod:`hybobs_opt.mhe.certify`).  The package implements the
runtime contract of :mod:`hybobs_opt.contract` and sits below the runtime-observer package.
The problem is written once in CasADi (:class:`MHEFormulation`), from which every backend takes
its matrices; an ``extend`` callable adds cost terms, constraints and parameters to it through
an :class:`MHEExtension`.  The constant arrival weight tuned from the noise level is designed
offline by :func:`hybobs_opt.synthesis.certified_arrival_prior` (an LMI: never more information
than a Kalman filter has under any mode sequence).
:class:`SetMembershipObserver` states, under a bound on the output noise, the box of every state
consistent with the window: an estimate with a certified radius.  With Gaussian noise and the
Kalman arrival cost, a flagged window's covariance is the mixture over every mode sequence that
fits it (:func:`sequence_mixture`).
"""

from .._lazy import lazy_exports
from .arrival import KalmanArrival
from .certify import SequenceSearch, search_sequences
from .formulation import MHEExtension, MHEFormulation
from .mixture import SequenceMixture, sequence_mixture
from .mld import MLDEncoding, big_m_constants, encode_mld
from .observer import NORMS, SOLVERS, MHEObserver
from .result import WindowResult
from ..contract import noise_bound_vector
from .set_membership import SetMembershipObserver
from .settings import MHESettings
from .uniqueness import SeparatedProgram, UniquenessOutcome

#: The arrival-weight design moved to :mod:`hybobs_opt.synthesis` (``FutureWarning`` until 0.2.0).
__getattr__, __dir__ = lazy_exports(__name__, {}, dict.fromkeys(("ArrivalPrior", "certified_arrival_prior"), "hybobs_opt.synthesis"))

__all__ = ["KalmanArrival", "MHEExtension", "MHEFormulation", "MHEObserver", "MHESettings", "MLDEncoding", "NORMS", "SOLVERS", "SeparatedProgram", "SequenceMixture", "SequenceSearch", "SetMembershipObserver",
           "UniquenessOutcome", "WindowResult", "big_m_constants", "encode_mld", "noise_bound_vector",
           "search_sequences", "sequence_mixture"]
