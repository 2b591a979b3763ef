"""The nouns a user describes: PWA systems, hybrid automata, constant-drift and scalar-nonlinear
systems, and the polytopes they are built of; with the forms derived from them (the observability
canonical form of a hybrid automaton, paper 001; the event-sampled periodic system of a
constant-drift system, paper 003); and the named examples that installed catalogues offer
(:func:`get_example`, :mod:`hybobs_opt.systems.catalogue`).  Names are imported on first use.
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("LocationTransform", "ObservabilityForm", "SwitchingFunction", "Theorem1Result",
                     "location_transforms", "observability_form", "observability_matrix", "theorem1", "theorem1_pairs"),
                    "hybobs_opt.systems.canonical_form"),
    **dict.fromkeys(("AugmentedSystem", "augment_parameters"), "hybobs_opt.systems.parameters"),
    "ConstantDriftSystem": "hybobs_opt.systems.constant_drift",
    **dict.fromkeys(("EventMaps", "PeriodicSystem", "event_maps", "periodic_system", "phase_augmented_pwa",
                     "visible_event_set"), "hybobs_opt.systems.event_sampled"),
    **dict.fromkeys(("Edge", "HybridAutomaton", "Location"), "hybobs_opt.systems.hybrid"),
    "Polytope": "hybobs_opt.geometry.polytope",
    **dict.fromkeys(("PWAMode", "PWASystem", "check_partition"), "hybobs_opt.systems.pwa"),
    **dict.fromkeys(("load_model", "model_schema", "read_model_dict", "save_model"), "hybobs_opt.systems.model_file"),
    **dict.fromkeys(("parse_expression", "expression_text"), "hybobs_opt.systems.expressions"),
    "system_fingerprint": "hybobs_opt.systems.fingerprint",
    **dict.fromkeys(("ScalarFunction", "ScalarNonlinearSystem"), "hybobs_opt.systems.scalar_nonlinear"),
    **dict.fromkeys(("register_resolver", "resolve_system"), "hybobs_opt.systems.resolve"),
    **dict.fromkeys(("get_example", "list_examples"), "hybobs_opt.systems.catalogue"),
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = sorted(_EXPORTS)
