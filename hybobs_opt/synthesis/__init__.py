"""Offline observer designs with their certificates: every gain, weight and bound computed before an
observer runs.  The runtime objects that use them are in :mod:`hybobs_opt.observers` and
:mod:`hybobs_opt.mhe`.

==================================  =========================================================================
design                              paper, module
==================================  =========================================================================
``design_residual_bank``            000, residual generators of the location observer, decay LMI (:mod:`.location_design`)
``design_continuous_observer``      000, continuous observer gains with a common ``P``, bound (20) (:mod:`.continuous_design`)
``design_gains``                    001, sliding-mode gains by the explicit range rule (:mod:`.sliding_mode_gains`)
``deadbeat_gains``                  003, deadbeat periodic gains by the sequential algorithm (:mod:`.periodic_gains`)
``positive_observer``               003, positive periodic gains, copositive Lyapunov LP (:mod:`.periodic_gains`)
``certified_arrival_prior``         002, MHE arrival weight certified for every mode sequence (:mod:`.arrival_weight`)
==================================  =========================================================================

Paper 004's designs -- observer LMIs, their infeasibility certificates, switched gains and the
dwell time -- form the sub-package :mod:`hybobs_opt.lmi` of the same tier (the design card names
it).  Every certificate derives from :class:`hybobs_opt.results.Certificate` (``reason``,
``verify()`` in numpy, ``to_dict()``).  This package sits below ``mhe`` and ``observers`` and
imports neither.  Names are imported on first use.
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("DelayCertificate", "LuenbergerLMI", "ResidualBank", "ResidualGenerator", "design_residual_bank"),
                    "hybobs_opt.synthesis.location_design"),
    **dict.fromkeys(("ContinuousDesign", "ContinuousObserverLMI", "ConvergenceBound", "MismatchPair", "convergence_bound",
                     "design_continuous_observer"), "hybobs_opt.synthesis.continuous_design"),
    **dict.fromkeys(("GainRule", "design_gains", "discretization_band", "reaching_time_bounds"),
                    "hybobs_opt.synthesis.sliding_mode_gains"),
    **dict.fromkeys(("CopositiveCertificate", "DeadbeatConflictCertificate", "NoDeadbeatCertificate", "PerronCertificate",
                     "PeriodicGains", "analyse_gains", "deadbeat_gains", "positive_deadbeat_gains", "positive_gain_bounds",
                     "positive_observer"), "hybobs_opt.synthesis.periodic_gains"),
    **dict.fromkeys(("ArrivalPrior", "certified_arrival_prior"), "hybobs_opt.synthesis.arrival_weight"),
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = sorted(_EXPORTS)
