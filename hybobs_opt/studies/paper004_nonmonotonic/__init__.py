"""Paper 004 (Rajamani et al.): switched-gain observers for non-monotonic nonlinear systems.

* :mod:`.systems` -- the radar-tracked vehicle (eqs. 56-59) and the magnetic piston (eq. 63);
* :mod:`.piston_pwa` -- the piston's sensors fitted piecewise-linearly (a PWA system for the lookup observer);
* :mod:`.presets` -- the published scheduling settings (``hybobs diagnose`` / ``hybobs synth``);
* :mod:`.scenarios` -- the switched-gain observer runs and ``hybobs observe``;
* :mod:`.piston_comparison` -- switched gains against the lookup-table deadbeat observer;
* :mod:`.paper_design` -- the vehicle's published gains (eqs. 61-62) against the synthesised ones.
"""

from ..registry import Example, register

_SYSTEMS = f"{__name__}.systems"

register(Example(
    name="vehicle_tracking", kind="scalar_nonlinear", paper="004",
    summary="Bicycle model of a radar-tracked vehicle (eqs. 56-59): non-monotonic V cos/sin(psi) dynamics",
    state_names=("X", "Y", "psi", "delta_f"), state_units=("m", "m", "rad", "rad"),  # Sec. 6.1
    build=f"{_SYSTEMS}:vehicle_tracking", scenario=f"{_SYSTEMS}:vehicle_scenario",
    default_t_final=30.0,  # VEHICLE_T_FINAL
    sample_time=1e-2, observers=("switched", "single"),
    params={"V": 10.0, "l_f": 1.1, "l_r": 1.58, "delta_max_deg": 10.0, "position_range": 500.0},
))
register(Example(
    name="magnetic_piston", kind="scalar_nonlinear", paper="004",
    summary="Piston position from two non-monotonic magnetic sensors (eq. 63), synthetic sensor curves",
    state_names=("z", "v", "a"), state_units=("mm", "mm/s", "mm/s^2"),  # Sec. 7: 0-203 mm
    build=f"{_SYSTEMS}:magnetic_piston", scenario=f"{_SYSTEMS}:piston_scenario",
    default_t_final=4.0,  # PISTON_PERIOD_S
    sample_time=1e-3, observers=("switched", "single"),
    params={"stroke": 203.0, "v_max": 500.0, "a_max": 5000.0},
))
