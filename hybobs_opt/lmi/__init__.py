"""Observer LMIs, Jacobian bounds, infeasibility certificates and switched gains (paper 004).

Modules, one concept each:

* :mod:`.schedule` -- regions of a scheduling coordinate (sub-boxes of the operating box);
* :mod:`.bounds` -- Jacobian bounds (eqs. 4-5), monotonicity, slope changes, monotonic pieces;
* :mod:`.observer_lmi` -- LMIs (8), (22), (23) compiled once with cvxpy ``Parameter`` objects;
* :mod:`.certificates` -- infeasibility certificates (structural reason, dual multiplier, numpy re-check);
* :mod:`.polytopic` -- the polytopic condition (one ``P`` on every vertex of the Jacobian box) and its certificate;
* :mod:`.hierarchy` -- the conditions weakest claim first (paper LMI, one multiplier per function, polytopic);
* :mod:`.impossibility` -- results for every gain: undetectable points, indistinguishable mirror states;
* :mod:`.subtraction` -- Theorem 5 (linear subtraction does not help);
* :mod:`.dwell` -- dwell time (eqs. 47-48) searched jointly over the ``P_i``, hysteresis;
* :mod:`.switched` -- per-region synthesis and automatic region growth;
* :mod:`.decay_design` -- the decay-optimal constant gain within a gain bound, over every condition;
* :mod:`.gain_search` -- the polytopic condition under the exact gain bound, searched locally;
* :mod:`.noise_gain` -- the gain with the smallest certified error bound under bounded noise (invariant ellipsoid);
* :mod:`.noise_sim` -- simulations of the observer under bounded noise that check that bound;
* :mod:`.switched_noise` -- the switched observer's certified error bound under bounded noise, with its dwell time;
* :mod:`.switched_noise_sim` -- simulations of the switched observer under bounded noise that check that bound;
* :mod:`.diagnose` -- the verdict, certificate and remedy for one range;
* :mod:`.auto_design` -- design settings (coordinate, scaling, gain bound, decay) read from the model;
* :mod:`.plots` -- figures of the results (the Jacobian bounds of a diagnosis; loads matplotlib on first use).

The paper examples' scheduling settings are the study :mod:`hybobs_opt.studies.paper004_nonmonotonic.presets`;
the commands ``hybobs diagnose`` / ``hybobs synth`` live in :mod:`hybobs_opt.cli`.
"""

from .._lazy import lazy_exports
from .auto_design import DesignSettings, design_settings, design_switched, scheduling_candidates
from .bounds import DerivativeBound, JacobianBounds, derivative_bound, jacobian_bounds, monotonic_pieces, slope_change_points
from .certificates import DualCertificate, InfeasibilityCertificate, certify_infeasible
from .decay_design import ConditionDecay, DecayDesign, decay_optimal_design
from .diagnose import Diagnosis, diagnose
from .gain_search import GainSearchResult, SearchStart, decay_gain_search, gain_decay_rate
from .hierarchy import CONDITIONS, ConditionResult, HierarchyResult, condition_hierarchy
from .impossibility import OutputSymmetry, UndetectablePoint, output_symmetries, undetectable_points
from .polytopic import PolytopicCertificate, PolytopicLMI
from .dwell import DwellTimeLMI, dwell_for_hysteresis, dwell_time_fixed, hysteresis_for_dwell
from .observer_lmi import LMISolution, ObserverLMI
from .schedule import SchedulingRegion, adjacent_pairs, make_region, regions_from_switch_points
from .solve import COUNTERS
from .subtraction import SubtractionCheck, theorem5_check
from .switched import DwellTimeError, DwellTimeWarning, RegionGain, SwitchedDesign, grow_regions, synthesize_switched

# Figures import matplotlib: imported on first use.
# The noise-gain SDPs are imported on first use too (they build cvxpy problems of their own).
__getattr__, __dir__ = lazy_exports(__name__, {
    **dict.fromkeys(("plot_jacobian_bounds", "plot_noise_tradeoff"), "hybobs_opt.lmi.plots"),
    **dict.fromkeys(("NoiseBoundDesign", "NoiseTradeoff", "noise_optimal_design", "noise_tradeoff"),
                    "hybobs_opt.lmi.noise_gain"),
    **dict.fromkeys(("StateCertificate", "SwitchedNoiseBound", "switched_noise_bound"), "hybobs_opt.lmi.switched_noise"),
    **dict.fromkeys(("SwitchedNoiseSimulationCheck", "check_switched_noise_bound"), "hybobs_opt.lmi.switched_noise_sim"),
})

__all__ = [
    "ConditionDecay", "DecayDesign", "NoiseBoundDesign", "NoiseTradeoff", "decay_optimal_design", "noise_optimal_design",
    "noise_tradeoff", "plot_noise_tradeoff", "GainSearchResult", "SearchStart", "decay_gain_search", "gain_decay_rate",
    "StateCertificate", "SwitchedNoiseBound", "switched_noise_bound", "SwitchedNoiseSimulationCheck",
    "check_switched_noise_bound",
    "COUNTERS", "CONDITIONS", "ConditionResult", "DwellTimeError", "DwellTimeWarning", "HierarchyResult", "OutputSymmetry",
    "PolytopicCertificate", "PolytopicLMI", "UndetectablePoint", "condition_hierarchy", "output_symmetries",
    "undetectable_points", "DerivativeBound", "DesignSettings", "design_settings", "design_switched", "scheduling_candidates", "Diagnosis", "DualCertificate", "DwellTimeLMI", "InfeasibilityCertificate",
    "JacobianBounds", "LMISolution", "ObserverLMI", "RegionGain", "SchedulingRegion", "SubtractionCheck",
    "SwitchedDesign", "adjacent_pairs", "certify_infeasible", "derivative_bound", "diagnose", "dwell_for_hysteresis",
    "dwell_time_fixed", "grow_regions", "hysteresis_for_dwell", "jacobian_bounds", "make_region", "monotonic_pieces",
    "plot_jacobian_bounds", "regions_from_switch_points", "slope_change_points", "synthesize_switched", "theorem5_check",
]
