"""Paper 001 (Djemai, Manamanni, Barbot): sliding-mode observers for nonlinear hybrid systems.

* :mod:`.systems` -- Examples 1-3 (switched unstable centres, the triangular system (6), the
  double scroll) with their scenarios and the canonical-form data of the paper;
* :mod:`.scenarios` -- the observer runs of Figs. 3-7, the filter trade-off and ``hybobs observe``;
* :mod:`.comparison` -- observer (5) against the lookup-table deadbeat observer on the double scroll.
"""

from ..registry import Example, register

_SYSTEMS = f"{__name__}.systems"

#: Observer kinds of ``hybobs observe`` on the three examples: observer (5) (aliases accepted by
#: :mod:`.scenarios`), with the low-pass filtered variant as an option.
SLIDING_MODE_KINDS = ("sliding-mode", "sliding_mode", "smo")

register(Example(
    name="switched_unstable", kind="hybrid_automaton", paper="001",
    summary="Example 1: two stable linear centres switched by sign(x1 x2) into an unstable system (Fig. 3)",
    state_names=("x1", "x2"), build=f"{_SYSTEMS}:switched_unstable", scenario=f"{_SYSTEMS}:_scenario_switched_unstable",
    default_t_final=10.0, params={"as_printed": False, "bound": 100.0}, sample_time=1e-2,
    observers=SLIDING_MODE_KINDS, observer_filter=True,
))
register(Example(
    name="triangular", kind="hybrid_automaton", paper="001",
    summary="Example 2: triangular 3rd-order system (6), x3' = F1 if x2 < 0 else F2, y = x1 (Fig. 4-6)",
    state_names=("x1", "x2", "x3"), build=f"{_SYSTEMS}:triangular", scenario=f"{_SYSTEMS}:_scenario_triangular",
    default_t_final=3.0, params={"bound_x1": 10.0, "bound_x2": 1.0, "bound_x3": 1.0}, sample_time=1e-3,
    observers=SLIDING_MODE_KINDS, observer_filter=True,
))
register(Example(
    name="double_scroll", kind="hybrid_automaton", paper="001",
    summary="Example 3: double-scroll PWA system (Chua), 3 locations split at x1 = +-1, y = x3 (Fig. 7)",
    state_names=("x1", "x2", "x3"), build=f"{_SYSTEMS}:double_scroll", scenario=f"{_SYSTEMS}:_scenario_double_scroll",
    default_t_final=50.0, params={"bounds": (3.0, 1.0, 5.0)}, sample_time=1e-2,
    observers=SLIDING_MODE_KINDS, observer_filter=True,
))
