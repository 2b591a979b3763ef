"""Paper 000 (Balluchi, Benvenuti, Di Benedetto, Sangiovanni-Vincentelli): a hybrid observer for
the driveline with discontinuous elasticity.

* :mod:`.systems` -- the driveline automaton ``H_drvln`` (eqs. 1-2, Fig. 1) and its torque-step scenario;
* :mod:`.scenario` -- the observer study of Fig. 6 (residual bank, continuous observer, ``hybobs observe driveline``);
* :mod:`.comparison` -- the hybrid observer against the lookup-table deadbeat observer (report).
"""

from ..registry import Example, register

register(Example(
    name="driveline",
    kind="hybrid_automaton",
    paper="000",
    summary="driveline with discontinuous elasticity (backlash), 3 locations, -10 N m torque step at 2 s (Fig. 6)",
    state_names=("theta_e", "omega_c", "omega_p"),
    # paper 000, Sec. 2: torsion angle (rad), crankshaft and wheel speeds (rad/sec)
    state_units=("rad", "rad/s", "rad/s"),
    build=f"{__name__}.systems:driveline",
    scenario=f"{__name__}.systems:scenario",
    default_t_final=4.0,
    sample_time=1e-3,
    observers=("hybrid",),  # location observer + continuous observer (Fig. 6)
    # TABLE1 of :mod:`.systems` (tests check the two agree)
    params={"alpha": 1.0 / 12.0, "Je": 0.30, "Jv": 140.0, "Be": 2.0, "bsm": 0.0, "k": 0.0, "k1": 1e4,
            "theta1": 0.015, "theta_e0": 0.025},
))
