"""Paper 002: observability regions and deadbeat observers for PWA powertrains with backlash.

* :mod:`.systems` -- models (16) and (17) with Tables 1-2 and the backlash-crossing scenario;
* :mod:`.bench` -- the lookup observer against the MIQP/MILP moving-horizon observers on the
  scenario (Section 7, Figs. 7-9; ``hybobs bench`` and ``hybobs observe powertrain3``);
* :mod:`.figures` -- the cut planes and helpers of the region figures (Section 6, Figs. 3-6).
"""

from ..registry import Example, register

_SYSTEMS = f"{__name__}.systems"

register(Example(
    name="powertrain3", kind="pwa", paper="002",
    summary="3rd-order powertrain with backlash, model (16) + Table 1, Ts = 1 ms, 3 dead-zone modes",
    state_names=("theta", "omega_m", "omega_l"), state_units=("rad", "rad/s", "rad/s"),  # Sec. 5.1
    build=f"{_SYSTEMS}:powertrain3", scenario=f"{_SYSTEMS}:_scenario3",
    default_t_final=3.0, params={"gear_ratio": 1.0 / 12.0},  # TABLE1["gear_ratio"]
    sample_time=1e-3, observers=("lookup", "miqp", "milp", "milp_inf"),
))
register(Example(
    name="powertrain5", kind="pwa", paper="002",
    summary="5th-order powertrain with flexible clutch and backlash, model (17) + Table 2, Ts = 1 ms",
    state_names=("theta_mc", "theta_cl", "omega_m", "omega_c", "omega_l"),
    state_units=("rad", "rad", "rad/s", "rad/s", "rad/s"), build=f"{_SYSTEMS}:powertrain5",
    scenario=f"{_SYSTEMS}:_scenario5", default_t_final=3.0, params={"gear_ratio": 1.0 / 6.9576},  # TABLE2
    sample_time=1e-3, observers=("lookup", "miqp", "milp", "milp_inf"),
))
