"""Paper 004's observer study: the switched-gain observer with the preset designs on the vehicle
(Sec. 6, Figs. 3-4) and the piston (Sec. 7), and ``hybobs observe vehicle_tracking /
magnetic_piston``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.contract import ObserverTrace
from hybobs_opt.observers.switched_gain import SwitchedGainObserver, convergence_time
from hybobs_opt.studies.registry import get_example

from .presets import get_preset

#: Initial estimates of the scenarios.  Vehicle: paper 004 Sec. 6.2 ("the vehicle estimates are
#: located at (0,0) and oriented with 0 degree yaw angle").  Piston: no scenario in the paper; the
#: estimate starts 4 mm off in position and at rest (an assumption).
VEHICLE_X_HAT0 = (0.0, 0.0, 0.0, 0.0)
PISTON_POSITION_ERROR_MM = 4.0

#: Convergence thresholds of the summaries (per state, model units): the error must stay below
#: them from the convergence time on.  Vehicle: 0.1 m and 0.5 deg; piston: 0.5 mm and 5 mm/s.
CONVERGENCE_TOL = {
    "vehicle_tracking": {"X": 0.1, "Y": 0.1, "psi": math.radians(0.5)},
    "magnetic_piston": {"z": 0.5, "v": 5.0},
}

#: Periodic coordinates of the examples (model units), wrapped by the observer instead of clipped
#: to the box: the vehicle's yaw is an angle, its box [0, 2 pi] one turn, so an estimate
#: that passes 360 deg is the same heading near 0 deg (clipped, it stuck at the box's edge).
PERIODIC = {
    "vehicle_tracking": {"psi": 2 * math.pi},
    "magnetic_piston": None,
}


@lru_cache(maxsize=4)
def cached_design(example: str):
    """The preset design of an example (synthesised once per process)."""
    from .presets import preset_design

    return preset_design(example)


def run_example(example: str, kind: str = "switched", *, design=None, x_hat0: Sequence[float] | None = None,
                t_final: float | None = None) -> tuple[Any, ObserverTrace, dict]:
    """Simulate the example's scenario and run the observer on it.

    Parameters
    ----------
    example : str
        ``"vehicle_tracking"`` or ``"magnetic_piston"``.
    kind : {"switched", "single"}
        The switched-gain observer, or the first region's gain alone (Fig. 4 of paper 004).
    design : SwitchedDesign, optional
        Default: :func:`cached_design`.
    x_hat0 : array, optional
        Initial estimate (defaults: :data:`VEHICLE_X_HAT0`, the piston's true start + 4 mm).

    The observer wraps the example's :data:`PERIODIC` coordinates (the vehicle's yaw modulo
    2 pi); the summary's errors of those coordinates are measured along the circle.

    Returns
    -------
    (Trace, ObserverTrace, dict)
        The true trace, the estimates and the JSON summary.
    """
    if kind not in ("switched", "single"):
        raise ModelError("--observers", "'switched' or 'single'", repr(kind))
    ex = get_example(example)
    if ex.name not in CONVERGENCE_TOL:
        raise ModelError("example", f"one of {sorted(CONVERGENCE_TOL)}", repr(example))
    design = design if design is not None else cached_design(ex.name)
    system = design.system
    trace = ex.scenario(system, t_final)
    if x_hat0 is None:
        if ex.name == "vehicle_tracking":
            x_hat0 = VEHICLE_X_HAT0
        else:
            x_hat0 = trace.x[0] * np.array([1.0, 0.0, 0.0]) + np.array([PISTON_POSITION_ERROR_MM, 0.0, 0.0])
    gains = design.regions if kind == "switched" else design.regions[:1]
    dt = float(trace.t[1] - trace.t[0])
    obs = SwitchedGainObserver(system, gains, dt, periodic=PERIODIC.get(ex.name))
    obs.reset(np.asarray(x_hat0, dtype=float))
    if kind == "single":
        obs.name = "single-gain"
    ot = obs.run(trace.u, trace.y)
    summary = summarize(ex.name, trace, ot, obs, design, kind)
    return trace, ot, summary


def summarize(example: str, trace, ot: ObserverTrace, obs: SwitchedGainObserver, design, kind: str) -> dict:
    """The JSON summary of a run: error metrics, convergence time, regions visited, step times."""
    err = obs.difference(ot.x_hat, trace.x)  # = ot.errors(trace.x), periodic coordinates along the circle
    names = trace.state_names
    tol_map = CONVERGENCE_TOL[example]
    idx = [names.index(k) for k in tol_map]
    tol = np.array([tol_map[k] for k in tol_map])
    t = trace.t
    conv = convergence_time(t, err[:, idx], tol)
    modes = ot.mode
    visited = [int(m) for i, m in enumerate(modes) if m >= 0 and (i == 0 or m != modes[i - 1])]
    switches = [{"t": float(t[i]), "from": int(modes[i - 1]), "to": int(modes[i])}
                for i in range(1, modes.size) if modes[i] != modes[i - 1] and modes[i - 1] >= 0]
    half = t >= 0.5 * t[-1]
    k = obs.k
    preset = get_preset(example)
    factor, unit = preset.factor, preset.unit
    out = {
        "example": example,
        "observer": "switched-gain" if kind == "switched" else "single-gain (first region's gain)",
        "regions": [[r.lo / factor, r.hi / factor] for r in obs.regions],
        "coordinate": names[k], "unit": unit,
        "periodic": {names[i]: p for i, p in sorted(obs.periodic.items())},
        "rms_error": {n: float(np.sqrt(np.mean(err[:, i] ** 2))) for i, n in enumerate(names)},
        "rms_error_second_half": {n: float(np.sqrt(np.mean(err[half, i] ** 2))) for i, n in enumerate(names)},
        "max_abs_error_second_half": {n: float(np.max(np.abs(err[half, i]))) for i, n in enumerate(names)},
        "final_abs_error": {n: float(abs(err[-1, i])) for i, n in enumerate(names)},
        "convergence_tolerance": dict(tol_map),
        "convergence_time": conv,
        "converged": conv is not None,
        "regions_visited": visited,
        "n_switches": len(switches),
        "switches": switches,
        "initial_selection": obs.selected,
        "flags": ot.flag_counts(),
        "timing": ot.timing(),
        "substeps": obs.substeps,
        "tau": design.tau,
        "samples": int(t.size),
    }
    return out


def _scenario(example: str):
    def scenario(args) -> dict:
        kind = getattr(args, "observer", None) or "switched"
        trace, ot, summary = run_example(example, kind)
        plot = getattr(args, "plot", None)
        if plot:
            from hybobs_opt.observers.plots import plot_observer_run

            plot_observer_run(trace, [ot], plot, title=f"{example}: {summary['observer']}")
            summary["plot"] = str(plot)
        return summary

    return scenario


#: The study's scenario runner under the name every study uses.
run_scenario = run_example


def register_scenarios(register) -> None:
    """``hybobs observe vehicle_tracking / magnetic_piston``."""
    register("vehicle_tracking", _scenario("vehicle_tracking"))
    register("magnetic_piston", _scenario("magnetic_piston"))
