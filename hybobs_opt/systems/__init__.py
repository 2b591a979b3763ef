"""The nouns a user describes: PWA systems, hybrid automata, constant-drift and scalar-nonlinear
systems, and the polytopes they are built of.  Names are imported on first use.
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    "ConstantDriftSystem": "hybobs_opt.systems.constant_drift",
    **dict.fromkeys(("Edge", "HybridAutomaton", "Location"), "hybobs_opt.systems.hybrid"),
    "Polytope": "hybobs_opt.systems.polytope",
    **dict.fromkeys(("PWAMode", "PWASystem"), "hybobs_opt.systems.pwa"),
    **dict.fromkeys(("ScalarFunction", "ScalarNonlinearSystem"), "hybobs_opt.systems.scalar_nonlinear"),
    **dict.fromkeys(("register_resolver", "resolve_system"), "hybobs_opt.systems.resolve"),
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = sorted(_EXPORTS)
