"""Simulators for every system class; all return a :class:`~hybobs_opt.sim.trace.Trace`."""

from .fixed_step import integrate_fixed_step, simulate_hybrid_fixed_step
from .hybrid import SimulationError, simulate_hybrid
from .pwa import simulate_pwa, simulate_pwa_batch
from .trace import Trace

__all__ = [
    "SimulationError",
    "Trace",
    "integrate_fixed_step",
    "simulate_hybrid",
    "simulate_hybrid_fixed_step",
    "simulate_pwa",
    "simulate_pwa_batch",
]
