"""Runtime observers with one contract (:mod:`hybobs_opt.contract`): ``reset(x0, q0=...)``,
``step(u, y) -> Estimate``, ``run(U, Y) -> ObserverTrace``.

==============================  ===========================================================
observer                        paper, module
==============================  ===========================================================
``LookupObserver``              002, deadbeat observer by lookup tables (:mod:`.lookup`; as C99: :mod:`.c_export`)
``NoiseAwareLookupObserver``    002 with noisy outputs: statistical tests per region (:mod:`.noise_lookup`)
``ParameterBank``               002 with an unknown parameter: lookup observers over a grid (:mod:`.parameter_bank`)
``SetMembershipFilter``         every sample so far, bounded noise: a union of polytopes (:mod:`.set_filter`)
``MHEObserver``                 002, MIQP/MILP moving horizon (:mod:`hybobs_opt.mhe`)
``LocationObserver``            000, residual-bank location observer (:mod:`.location_observer`)
``HybridObserver``              000, location + continuous observer (:mod:`.hybrid_observer`)
``SlidingModeObserver``         001, step-by-step sliding modes (:mod:`.sliding_mode`)
``DriftObserver``               003, constant-drift observer (18) (:mod:`.drift_observer`)
``PeriodicObserver``            003, event-sampled periodic observer (:mod:`.periodic`)
``SwitchedGainObserver``        004, switched gains with hysteresis (:mod:`.switched_gain`)
``ModeSequenceKalmanFilter``    Kalman filter told the true modes: the noise bench's reference (:mod:`.kalman`)
==============================  ===========================================================

Names are imported on first use (``from hybobs_opt.observers import LookupObserver``).  Their
offline designs (gains, residual banks, bounds) are in :mod:`hybobs_opt.synthesis`.
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("FALLBACK", "OBSERVABLE", "UNOBSERVABLE", "WARMING_UP", "Estimate", "Observer", "ObserverTrace",
                     "noise_bound_vector", "radius_tolerance_vector"), "hybobs_opt.contract"),
    **dict.fromkeys(("LookupObserver", "LookupTrace", "REASONS", "input_bound_rows"), "hybobs_opt.observers.lookup"),
    **dict.fromkeys(("BUILD_FLAGS", "CExport", "check_build", "export_lookup_c", "export_targets"),
                    "hybobs_opt.observers.c_export"),
    "NoiseAwareLookupObserver": "hybobs_opt.observers.noise_lookup",
    **dict.fromkeys(("ParameterBank", "ParameterBankTrace"), "hybobs_opt.observers.parameter_bank"),
    "SetMembershipFilter": "hybobs_opt.observers.set_filter",
    "MHEObserver": "hybobs_opt.mhe",
    **dict.fromkeys(("LocationObserver", "detection_delays"), "hybobs_opt.observers.location_observer"),
    **dict.fromkeys(("ContinuousObserver", "HybridObserver", "HybridRun", "summarise_run"),
                    "hybobs_opt.observers.hybrid_observer"),
    "SlidingModeObserver": "hybobs_opt.observers.sliding_mode",
    **dict.fromkeys(("DriftObserver", "DriftRun"), "hybobs_opt.observers.drift_observer"),
    "PeriodicObserver": "hybobs_opt.observers.periodic",
    **dict.fromkeys(("SwitchedGainObserver", "convergence_time"), "hybobs_opt.observers.switched_gain"),
    **dict.fromkeys(("exact_window_labels", "summarise", "timed_steps", "true_window_observable", "wilson_interval"),
                    "hybobs_opt.observers.comparison"),
    "plot_observer_run": "hybobs_opt.observers.plots",
    **dict.fromkeys(("KalmanTrace", "ModeSequenceKalmanFilter"), "hybobs_opt.observers.kalman"),
}

#: Designs that moved to :mod:`hybobs_opt.synthesis` (served with a ``FutureWarning`` until 0.2.0).
_MOVED: dict[str, str] = dict.fromkeys(
    ("ContinuousDesign", "ConvergenceBound", "GainRule", "PeriodicGains", "ResidualBank", "convergence_bound",
     "deadbeat_gains", "design_continuous_observer", "design_gains", "design_residual_bank", "discretization_band",
     "positive_deadbeat_gains", "positive_gain_bounds", "positive_observer"), "hybobs_opt.synthesis")

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, _MOVED)

__all__ = sorted(_EXPORTS)
