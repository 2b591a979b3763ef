"""Simulators for every system class; all return a :class:`~hybobs_opt.sim.trace.Trace`.

Names are imported on first use: ``from hybobs_opt.sim.pwa import simulate_pwa`` (a study's
example, an analysis) loads neither SciPy's integrators (:mod:`.hybrid`) nor CasADi
(:mod:`.nonlinear`).
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    "simulate_system": ".any_system",
    "simulate_constant_drift": ".constant_drift",
    **dict.fromkeys(("integrate_fixed_step", "simulate_hybrid_fixed_step"), ".fixed_step"),
    **dict.fromkeys(("SimulationError", "simulate_hybrid"), ".hybrid"),
    **dict.fromkeys(("InputTable", "read_input_table"), ".input_table"),
    "simulate_nonlinear": ".nonlinear",
    **dict.fromkeys(("simulate_pwa", "simulate_pwa_batch"), ".pwa"),
    "Trace": ".trace",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
