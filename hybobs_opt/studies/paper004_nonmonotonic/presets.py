"""Scheduling settings of the paper 004 examples for ``hybobs diagnose`` / ``hybobs synth``.

Each preset names the scheduling coordinate, the unit it is shown in, the default ranges, the
regions (the paper's switching point for the vehicle, automatic growth for the piston), the gain
bound, and the state scaling of the LMIs.  Values that are not in the paper say why they were chosen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.lmi.auto_design import max_rate  # noqa: F401  (was defined here; the rule is the model's)
from hybobs_opt.systems.scalar_nonlinear import ScalarNonlinearSystem


@dataclass(frozen=True)
class SchedulePreset:
    """How to schedule gains for one example.

    Attributes
    ----------
    example : str
    coordinate : str
        The scheduling state.
    unit : str
        Display unit of the coordinate (``"deg"``, ``"mm"``).
    factor : float
        Model units per display unit (``pi/180`` for degrees).
    diagnose_range, synth_range : (float, float)
        Default ranges in display units.
    switch_points : tuple of float or None
        Nominal switching points (display units); ``None``: grow the regions automatically.
    overlap : float
        Hysteresis ``epsilon`` (display units): neighbours overlap by ``2 epsilon``.
    gain_bound : float
        ``||L||_2`` bound of the synthesis (model units).
    min_decay : float
        Decay rate (1/s) each automatically grown region must admit.
    decay_fraction : float
        Design rate as a fraction of each region's largest rate.
    scaling : str
        ``"box"`` (half-widths of the operating box) or ``"vehicle"`` (see :func:`scaling_for`).
    sigma_cap : float
        Upper end of the decay-rate bisection (1/s).
    max_rate : float or None
        Maximum rate of the coordinate (display units/s) for the hysteresis; ``None``: the
        largest rate over the operating box (:func:`max_rate`).
    """

    example: str
    coordinate: str
    unit: str
    factor: float
    diagnose_range: tuple[float, float]
    synth_range: tuple[float, float]
    switch_points: tuple[float, ...] | None
    overlap: float
    gain_bound: float
    min_decay: float
    decay_fraction: float
    scaling: str = "box"
    sigma_cap: float = 100.0
    max_rate: float | None = None

    def to_model(self, value: float) -> float:
        return float(value) * self.factor

    def to_display(self, value: float) -> float:
        return float(value) / self.factor


PRESETS: dict[str, SchedulePreset] = {
    # Paper 004, Sec. 6: gains L_1 on 0-80 deg and L_2 on 60-140 deg (eqs. 61-62) -> nominal switch
    # at 70 deg with epsilon = 10 deg.  Gain bound 200: the paper's gains have ||L_1|| ~ 160 and
    # ||L_2|| ~ 90, so 200 keeps ours of the same size (not in the paper).
    "vehicle_tracking": SchedulePreset(
        "vehicle_tracking", "psi", "deg", math.pi / 180.0, (0.0, 360.0), (0.0, 140.0), (70.0,), 10.0,
        gain_bound=200.0, min_decay=1.0, decay_fraction=0.5, scaling="vehicle", sigma_cap=20.0),
    # Paper 004, Sec. 7: regions R_1..R_11 around the sensors' slope changes (Fig. 7); ours are grown
    # automatically on the synthetic curves.  Gain bound 1e6 (mT -> mm/s^3 for the jerk channel)
    # gives decay rates of 10-40 1/s, fast against the 4 s stroke; min_decay 10 1/s; epsilon = 1 mm
    # (0.5 % of the stroke).  The rate of z for the hysteresis is 160 mm/s, the scenario's peak speed
    # (152 mm/s) rounded up: the box's 500 mm/s is only a modelling bound.  Design rate 0.25 x the
    # largest: at 0.5 the joint dwell search gives tau = 0.028 s, which the 1 mm hysteresis does not
    # enforce at 160 mm/s (it needs 2.25 mm; wider overlaps grow more regions and longer dwell times:
    # 2.5 mm -> 13 regions, tau = 0.041 s, needs 3.3 mm); at 0.25 the regions share a common P
    # (tau = 0) and the dwell is enforced.  None of these is in the paper.
    "magnetic_piston": SchedulePreset(
        "magnetic_piston", "z", "mm", 1.0, (0.0, 203.0), (0.0, 203.0), None, 1.0,
        gain_bound=1e6, min_decay=10.0, decay_fraction=0.25, scaling="box", sigma_cap=200.0, max_rate=160.0),
}


#: Units of the nonlinear functions of the two examples, ``{function name: (value unit, argument
#: unit)}`` in model units (the slope axes of :func:`hybobs_opt.lmi.plots.plot_jacobian_bounds`):
#: the vehicle's velocity components (m/s) and yaw rate (rad/s) of the angles in rad (Sec. 6.1), the
#: piston's sensor readings (mT) of the position in mm (Sec. 7).
FUNCTION_UNITS: dict[str, dict[str, tuple[str, str]]] = {
    "vehicle_tracking": {"V cos(psi)": ("m/s", "rad"), "V sin(psi)": ("m/s", "rad"),
                         "V/(l_f+l_r) tan(delta_f)": ("rad/s", "rad")},
    "magnetic_piston": {"sensor 1": ("mT", "mm"), "sensor 2": ("mT", "mm")},
}


def get_preset(example: str) -> SchedulePreset:
    try:
        return PRESETS[example]
    except KeyError:
        raise ModelError("example", f"an example with a switched-gain preset (one of {sorted(PRESETS)})", repr(example)) from None


def scaling_for(preset: SchedulePreset, system: ScalarNonlinearSystem) -> np.ndarray | None:
    """State scaling of the LMIs (``None`` = box half-widths).

    The vehicle's box of relative positions (+-500 m) is an arbitrary assumption, and scaling by
    it leaves Clarabel with a badly conditioned problem; positions are scaled by the distance
    covered in one second instead (``V * 1 s``, taken as the largest ``|X'|``), the yaw by one
    radian and the steering by its bound.
    """
    if preset.scaling == "box":
        return None
    if preset.scaling == "vehicle":
        out = 0.5 * (system.box_upper - system.box_lower)
        for k, name in enumerate(system.state_names):
            if name in ("X", "Y"):
                out[k] = max(max_rate(system, k) * 1.0, 1e-9)  # distance covered in 1 s
            elif name == "psi":
                out[k] = 1.0
        return out
    raise ModelError("preset.scaling", "'box' or 'vehicle'", repr(preset.scaling))


def preset_regions(preset: SchedulePreset, system: ScalarNonlinearSystem, lo: float | None = None,
                   hi: float | None = None):
    """The preset's regions on ``[lo, hi]`` (display units; default: the synthesis range).

    The paper's switching points when the preset has them and they fall inside the range,
    otherwise regions grown automatically (:func:`.switched.grow_regions`).
    """
    from hybobs_opt.lmi.schedule import regions_from_switch_points
    from hybobs_opt.lmi.switched import grow_regions

    lo = preset.synth_range[0] if lo is None else float(lo)
    hi = preset.synth_range[1] if hi is None else float(hi)
    if not lo < hi:
        raise ModelError("range", "lo < hi (a non-empty range)", f"[{lo:g}, {hi:g}]")
    pts = [p for p in (preset.switch_points or ()) if lo + preset.overlap < p < hi - preset.overlap]
    if preset.switch_points and pts and (lo, hi) == tuple(preset.synth_range):
        return regions_from_switch_points(system, preset.coordinate, preset.to_model(lo), preset.to_model(hi),
                                          [preset.to_model(p) for p in pts], preset.to_model(preset.overlap))
    return grow_regions(system, preset.coordinate, preset.to_model(lo), preset.to_model(hi),
                        overlap=preset.to_model(preset.overlap), min_decay=preset.min_decay,
                        gain_bound=preset.gain_bound, scaling=scaling_for(preset, system))


def preset_design(example: str, system: ScalarNonlinearSystem | None = None, lo: float | None = None,
                  hi: float | None = None, *, rate: float | None = None, regions=None,
                  accept_unenforced_dwell: bool = False):
    """Regions, gains, dwell time and hysteresis of an example with its preset settings.

    Parameters
    ----------
    example : str
        ``"vehicle_tracking"`` or ``"magnetic_piston"``.
    system : ScalarNonlinearSystem, optional
        Default: the example's factory with its default parameters.
    lo, hi : float, optional
        Range in display units (default: the preset's synthesis range).
    rate : float, optional
        Maximum rate of the coordinate in display units/s (default: the preset's, else the box's).
    regions : sequence of SchedulingRegion, optional
        Use these regions instead of the preset's.
    accept_unenforced_dwell : bool
        Return a design whose hysteresis does not enforce the dwell time at the rate (else
        :class:`~hybobs_opt.lmi.switched.DwellTimeError`).
    """
    from hybobs_opt.studies import get_example
    from hybobs_opt.lmi.switched import synthesize_switched

    preset = get_preset(example)
    if system is None:
        system = get_example(example).build()
    k = system.state_names.index(preset.coordinate)
    if regions is None:
        regions = preset_regions(preset, system, lo, hi)
    if rate is None:
        rate_model = preset.to_model(preset.max_rate) if preset.max_rate is not None else max_rate(system, k)
    else:
        if not (np.isfinite(rate) and rate > 0):
            raise ModelError("max rate", "a positive rate of the scheduling variable", repr(rate))
        rate_model = preset.to_model(rate)
    return synthesize_switched(system, regions, gain_bound=preset.gain_bound, decay_fraction=preset.decay_fraction,
                               sigma_cap=preset.sigma_cap, scaling=scaling_for(preset, system), max_rate=rate_model,
                               overlap=preset.to_model(preset.overlap), accept_unenforced_dwell=accept_unenforced_dwell,
                               min_decay=preset.min_decay if preset.switch_points is None else None)
