"""hybobs_opt: optimization-based state observers for hybrid systems.

Three tiers (DESIGN.md; a test checks that every import points down):

* **core** -- ``geometry`` (polytopes, LPs), ``systems``, ``sim``, ``regions`` (observability of
  PWA systems, paper 002), ``synthesis`` (the offline designs of papers 000-003 and the MHE
  arrival weight, with certificates) and ``lmi`` (observer LMIs and certificates, paper 004),
  ``mhe`` (MIQP/MILP moving-horizon observers) and ``observers`` (the runtime observers, one
  contract);
* **studies** -- ``studies.paper000_driveline`` ... ``studies.paper004_nonmonotonic``: the seed
  papers' systems, scenarios, published settings and comparisons (the example registry);
* **application** -- ``cli`` (``hybobs``), ``report``.

The main objects are re-exported here and imported on first use, so ``import hybobs_opt`` is
cheap::

    from hybobs_opt import PWASystem, analyse_observability, LookupObserver, MHEObserver
"""

import logging

from ._lazy import lazy_exports
from .errors import BuildError, HybobsError, InfeasibleError, ModelError, SolverError


__version__ = "0.1.0"

_EXPORTS: dict[str, str] = {
    # vocabulary of every solve
    **dict.fromkeys(("Status", "is_infeasible", "is_optimal", "map_status"), "hybobs_opt.status"),
    **dict.fromkeys(("Certificate", "SolveResult"), "hybobs_opt.results"),
    # systems
    **dict.fromkeys(("ConstantDriftSystem", "Edge", "HybridAutomaton", "Location", "PWAMode", "PWASystem", "Polytope",
                     "ScalarFunction", "ScalarNonlinearSystem"), "hybobs_opt.systems"),
    **dict.fromkeys(("PeriodicSystem", "periodic_system"), "hybobs_opt.systems.event_sampled"),
    "observability_form": "hybobs_opt.systems.canonical_form",
    **dict.fromkeys(("load_model", "save_model", "model_schema"), "hybobs_opt.systems.model_file"),
    **dict.fromkeys(("register_resolver", "resolve_system"), "hybobs_opt.systems.resolve"),
    "check_partition": "hybobs_opt.systems.pwa",
    # simulators
    **dict.fromkeys(("InputTable", "Trace", "read_input_table", "simulate_constant_drift", "simulate_hybrid",
                     "simulate_hybrid_fixed_step", "simulate_nonlinear", "simulate_pwa", "simulate_pwa_batch",
                     "simulate_system"), "hybobs_opt.sim"),
    **dict.fromkeys(("SignalLog", "read_log", "write_estimates"), "hybobs_opt.sim.log"),
    # observability regions (paper 002)
    **dict.fromkeys(("ObservabilityAnalysis", "PointClass", "analyse_observability", "compute_cut", "enumerate_modes",
                     "load_analysis", "save_analysis"), "hybobs_opt.regions"),
    # LMI design (paper 004)
    **dict.fromkeys(("DesignSettings", "Diagnosis", "ObserverLMI", "SwitchedDesign", "design_settings", "design_switched", "diagnose", "dwell_time_fixed", "grow_regions",
                     "jacobian_bounds", "make_region", "synthesize_switched", "theorem5_check"), "hybobs_opt.lmi"),
    # runtime observers
    **dict.fromkeys(("Estimate", "Observer", "ObserverTrace"), "hybobs_opt.contract"),
    "MHEObserver": "hybobs_opt.mhe",
    "SetMembershipObserver": "hybobs_opt.mhe",
    "SetMembershipFilter": "hybobs_opt.observers.set_filter",
    "observe_log": "hybobs_opt.observers.recorded",
    **dict.fromkeys(("ContinuousObserver", "DriftObserver", "HybridObserver", "LocationObserver", "LookupObserver",
                     "PeriodicObserver", "SlidingModeObserver", "SwitchedGainObserver"), "hybobs_opt.observers"),
    # offline designs (papers 000-003; paper 004's are the LMI designs above)
    **dict.fromkeys(("deadbeat_gains", "design_continuous_observer", "design_gains", "design_residual_bank",
                     "positive_observer"), "hybobs_opt.synthesis"),
    # running work
    **dict.fromkeys(("DaskExecutor", "ProcessExecutor", "SerialExecutor", "make_executor"), "hybobs_opt.executor"),
    **dict.fromkeys(("ResultCache", "cached_analysis", "use_cache"), "hybobs_opt.cache"),
    "PhaseProgress": "hybobs_opt.progress",
    "warm_up": "hybobs_opt._warm_up",
    "verbose_logging": "hybobs_opt._logging",
    # the installed example catalogues (this package's: the seed papers' examples)
    **dict.fromkeys(("get_example", "list_examples"), "hybobs_opt.systems.catalogue"),
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

# The library convention: the package's loggers ("hybobs_opt.*") write nowhere unless the
# application configures logging (or passes verbose=True / hybobs -v: hybobs_opt._logging).
logging.getLogger(__name__).addHandler(logging.NullHandler())
del logging

__all__ = ["BuildError", "HybobsError", "InfeasibleError", "ModelError", "SolverError", "__version__", *sorted(_EXPORTS)]
