"""Simulators for every system class; all return a :class:`~hybobs_opt.sim.trace.Trace`."""

from .any_system import simulate_system
from .constant_drift import simulate_constant_drift
from .fixed_step import integrate_fixed_step, simulate_hybrid_fixed_step
from .hybrid import SimulationError, simulate_hybrid
from .input_table import InputTable, read_input_table
from .nonlinear import simulate_nonlinear
from .pwa import simulate_pwa, simulate_pwa_batch
from .trace import Trace

__all__ = [
    "InputTable",
    "SimulationError",
    "Trace",
    "integrate_fixed_step",
    "read_input_table",
    "simulate_constant_drift",
    "simulate_hybrid",
    "simulate_hybrid_fixed_step",
    "simulate_nonlinear",
    "simulate_pwa",
    "simulate_pwa_batch",
    "simulate_system",
]
