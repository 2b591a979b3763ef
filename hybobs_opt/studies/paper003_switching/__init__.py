"""Paper 003: observer design for piecewise affine hybrid systems with constant drift.

* :mod:`.systems` -- the two-product switching server (Section 2.1) and the signalized T-junction
  (Section 5) with their scenarios;
* :mod:`.scenarios` -- the paper's gains, the drift-observer runs and ``hybobs observe``;
* :mod:`.comparison` -- the periodic observers against the lookup-table deadbeat observer (report).
"""

from ..registry import Example, register

_SYSTEMS = f"{__name__}.systems"


def _kinds(kinds: tuple[str, ...]) -> tuple[str, ...]:
    """The observer kinds of :func:`.scenarios.scenario_gains`, each also with Remark 4.4's ``+projection``."""
    return kinds + tuple(f"{k}+projection" for k in kinds)


register(Example(
    name="switching_server", kind="constant_drift", paper="003",
    summary="Two-product switching server with setup times; only 'serving type 2' is visible (Sec. 2.1)",
    # remaining setup time, buffer contents (Sec. 2.1: "x_n jobs are stored"); the paper gives no time unit
    state_names=("x0", "x1", "x2"), state_units=("s", "jobs", "jobs"), build=f"{_SYSTEMS}:switching_server", scenario=f"{_SYSTEMS}:switching_server_scenario",
    default_t_final=60.0,  # SERVER_T_FINAL
    params={"lam1": 1.0, "mu1": 3.0, "mu2": 4.0, "gamma1": 2.0, "gamma2": 1.0},
    sample_time=0.1, observers=_kinds(("deadbeat", "positive", "positive-deadbeat")),
))
register(Example(
    name="traffic_junction", kind="constant_drift", paper="003",
    summary="Signalized 3-flow T-junction, clearing policy; sensor on lane 1 only (Sec. 5)",
    # remaining clearing time, queue lengths (Sec. 5; seconds and vehicles assumed, the paper gives none)
    state_names=("x0", "x1", "x2", "x3"), state_units=("s", "vehicles", "vehicles", "vehicles"), build=f"{_SYSTEMS}:traffic_junction", scenario=f"{_SYSTEMS}:traffic_junction_scenario",
    default_t_final=200.0,  # JUNCTION_T_FINAL
    params={"lam": (1.0, 2.0, 3.0), "mu": (8.0, 10.0, 12.0), "gamma": (5.0, 10.0, 15.0)},
    sample_time=0.1, observers=_kinds(("paper", "deadbeat", "positive", "positive-deadbeat")),
))
