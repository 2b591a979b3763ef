"""Constant-drift hybrid systems of paper 003: model checks, exact simulation, bad input.

The physics checks compute what the queues must do by hand (fractions, from lambda/mu/gamma)
and compare with the simulator.  The checks against numbers and formulas printed in paper 003
(Section 3.2 reduced matrices of the server, Section 5 matrices and event times of the
T-junction) are in ``tests/studies/test_paper003_switching.py``.
"""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.sim import Trace, simulate_constant_drift
from hybobs_opt.studies import get_example
from hybobs_opt.studies.paper003_switching.systems import switching_server, traffic_junction
from hybobs_opt.systems import ConstantDriftSystem

LAM = (1.0, 2.0, 3.0)
MU = (8.0, 10.0, 12.0)
GAMMA = (5.0, 10.0, 15.0)


@pytest.fixture(scope="module")
def junction() -> ConstantDriftSystem:
    return traffic_junction(lam=LAM, mu=MU, gamma=GAMMA)


@pytest.fixture(scope="module")
def paper_trace() -> Trace:
    return get_example("traffic_junction").simulate()


def _server_data() -> dict:
    """Section 2.1 data written out literally, lam1 = 1, mu1 = 3, mu2 = 4, gamma1 = 2, gamma2 = 1."""
    return dict(
        f=[[-1.0, 1.0, 0.0], [0.0, -2.0, 3.0], [-1.0, 1.0, 0.0], [0.0, 1.0, -4.0]],
        trigger=[0, 1, 0, 2],
        alpha=[0.0, 1.0, 0.0, 2.0],
        h=[0, 0, 0, 4],
    )


def _mode_intervals(trace: Trace) -> list[tuple[float, float, int]]:
    """(start, end, mode) of every stretch of constant mode, from the event log."""
    starts = [float(trace.t[0])] + [e["t"] for e in trace.events]
    ends = [e["t"] for e in trace.events] + [float(trace.t[-1])]
    modes = [int(trace.q[0])] + [e["to_mode"] for e in trace.events]
    return list(zip(starts, ends, modes))


def _time_in_mode(intervals, mode: int, ta: float, tb: float) -> float:
    return sum(max(0.0, min(e, tb) - max(s, ta)) for s, e, m in intervals if m == mode)


# ---------------------------------------------------------------------------- physics by hand


def test_junction_event_sequence_matches_hand_computation(junction):
    # One full cycle of the junction from x = [x0, x1, x2, x3] = [5, 40, 60, 0] in mode 1 (setup
    # for flow 1), computed by hand with exact fractions: every mode either lasts its setup time
    # or lasts until the served queue, draining at mu_i - lam_i, is empty.
    l1, l2, l3 = (F(v) for v in LAM)
    m1, m2, m3 = (F(v) for v in MU)
    g1, g2, g3 = (F(v) for v in GAMMA)
    t, x1, x2, x3 = F(0), F(40), F(60), F(0)
    hand = []
    # mode 1: clearing for flow 1 lasts gamma1 = 5
    d = g1
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    hand.append((t, 1, 2, (0, x1, x2, x3)))
    # mode 2: flow 1 served until queue 1 is empty
    d = x1 / (m1 - l1)
    t, x1, x2, x3 = t + d, F(0), x2 + l2 * d, x3 + l3 * d
    hand.append((t, 2, 3, (g2, x1, x2, x3)))
    # mode 3: clearing for flow 2 lasts gamma2
    d = g2
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    hand.append((t, 3, 4, (0, x1, x2, x3)))
    # mode 4: flow 2 served until empty
    d = x2 / (m2 - l2)
    t, x1, x2, x3 = t + d, x1 + l1 * d, F(0), x3 + l3 * d
    hand.append((t, 4, 5, (g3, x1, x2, x3)))
    # mode 5: clearing for flow 3 lasts gamma3
    d = g3
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    hand.append((t, 5, 6, (0, x1, x2, x3)))
    # mode 6: flow 3 served until empty
    d = x3 / (m3 - l3)
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, F(0)
    hand.append((t, 6, 1, (g1, x1, x2, x3)))
    # mode 1 again
    d = g1
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    hand.append((t, 1, 2, (0, x1, x2, x3)))

    # The same numbers, written out, so a slip in the derivation above cannot hide.
    assert [h[0] for h in hand] == [5, F(80, 7), F(150, 7), F(240, 7), F(345, 7), F(460, 7), F(495, 7)]
    assert hand[-1][3] == (0, F(415, 7), F(510, 7), 15)

    trace = simulate_constant_drift(junction, [5.0, 40.0, 60.0, 0.0], 1, 0.0, 75.0)
    assert len(trace.events) == len(hand)
    for ev, (t_h, frm, to, x_h) in zip(trace.events, hand):
        assert (ev["from_mode"], ev["to_mode"]) == (frm, to)
        assert ev["t"] == pytest.approx(float(t_h), rel=1e-12)
        np.testing.assert_allclose(ev["x"], [float(v) for v in x_h], rtol=1e-12, atol=1e-12)


def test_event_exactly_at_t_final_is_included(junction):
    # the setup of flow 1 from x0 = 5 ends at exactly t = 5: the event belongs to [t0, t_final]
    tr = simulate_constant_drift(junction, [5.0, 1.0, 0.0, 0.0], 1, 0.0, 5.0)
    assert [(e["t"], e["from_mode"], e["to_mode"]) for e in tr.events] == [(5.0, 1, 2)]
    assert tr.t.tolist() == [0.0, 5.0, 5.0] and tr.q.tolist() == [1, 1, 2]
    np.testing.assert_array_equal(tr.x[-1], [0.0, 6.0, 10.0, 15.0])


def test_queues_never_negative(junction):
    rng = np.random.default_rng(3)
    traces = [get_example("traffic_junction").simulate(t_final=400.0)]
    for _ in range(20):
        q0 = int(rng.integers(1, 7))
        x = rng.uniform(0.0, 100.0, 4)
        x[0] = rng.uniform(0.0, 15.0) if q0 % 2 == 1 else 0.0
        traces.append(simulate_constant_drift(junction, x, q0, 0.0, 300.0, dt=0.7))
    for tr in traces:
        assert np.all(tr.x >= 0.0), tr.x.min()
        # the queue that just emptied is exactly zero, not a rounding residue
        for e in tr.events:
            assert e["x_minus"][junction.trigger[e["from_mode"] - 1]] == 0.0


def test_conservation_queue_change_is_arrivals_minus_departures(paper_trace):
    tr = paper_trace
    intervals = _mode_intervals(tr)
    # pairs of sample times: whole horizon and a few arbitrary windows (grid and event rows)
    idx = [(0, tr.n_samples - 1), (10, 700), (523, 1410), (1, 2), (900, 901)]
    for a, b in idx:
        ta, tb = float(tr.t[a]), float(tr.t[b])
        for i in range(3):
            serving = _time_in_mode(intervals, 2 * (i + 1), ta, tb)
            arrivals = LAM[i] * (tb - ta)
            departures = MU[i] * serving
            assert tr.x[b, 1 + i] - tr.x[a, 1 + i] == pytest.approx(arrivals - departures, abs=1e-9)


def test_server_conservation_tandem_buffers():
    # Section 2.1: type-1 jobs served at mu1 move to buffer 2, which is emptied at mu2.
    lam1, mu1, mu2 = 1.0, 3.0, 4.0
    sys_ = switching_server(lam1=lam1, mu1=mu1, mu2=mu2, gamma1=2.0, gamma2=1.0)
    tr = simulate_constant_drift(sys_, [2.0, 10.0, 5.0], 1, 0.0, 50.0, dt=0.25)
    intervals = _mode_intervals(tr)
    ta, tb = float(tr.t[0]), float(tr.t[-1])
    s2 = _time_in_mode(intervals, 2, ta, tb)
    s4 = _time_in_mode(intervals, 4, ta, tb)
    assert tr.x[-1, 1] - tr.x[0, 1] == pytest.approx(lam1 * (tb - ta) - mu1 * s2, abs=1e-9)
    assert tr.x[-1, 2] - tr.x[0, 2] == pytest.approx(mu1 * s2 - mu2 * s4, abs=1e-9)
    assert np.all(tr.x >= 0.0)


def test_setup_modes_last_exactly_their_setup_time(paper_trace):
    # Lemma 2.8: the dwell in a timer mode is alpha of the preceding mode (gamma of the flow),
    # and Lemma 2.7: x0 = 0 just before every event.
    intervals = _mode_intervals(paper_trace)
    gamma_of_setup = {1: GAMMA[0], 3: GAMMA[1], 5: GAMMA[2]}
    full = intervals[1:-1]  # first and last stretches are cut by t0 / t_final
    checked = 0
    for s, e, m in full:
        if m in gamma_of_setup:
            assert e - s == pytest.approx(gamma_of_setup[m], abs=1e-9)
            checked += 1
    assert checked >= 6
    assert all(e["x_minus"][0] == 0.0 for e in paper_trace.events)


def test_cycle_length_converges_to_setup_over_idle_fraction(junction):
    # Work conservation: in the periodic regime the cycle length T satisfies
    # T = sum(gamma) + sum(lam_i T / mu_i), i.e. T = sum(gamma) / (1 - rho), rho = sum lam/mu.
    rho = sum(l / m for l, m in zip(LAM, MU))
    t_cycle = sum(GAMMA) / (1.0 - rho)
    tr = simulate_constant_drift(junction, [5.0, 40.0, 60.0, 0.0], 1, 0.0, 3000.0)
    starts = [e["t"] for e in tr.events if e["to_mode"] == 2]
    assert np.diff(starts)[-1] == pytest.approx(t_cycle, rel=1e-9)
    # and over every complete cycle queue 1 is emptied: served time = lam1 * cycle / mu1
    empties = [e["t"] for e in tr.events if e["from_mode"] == 2]
    for a, b, s in zip(empties[:-1], empties[1:], starts[1:]):
        assert (b - s) == pytest.approx(LAM[0] * (b - a) / MU[0], rel=1e-9)


def test_visibility_and_output(junction, paper_trace):
    assert junction.visible_modes == (2,)
    assert junction.visible_event_modes == (1, 2)
    for e in paper_trace.events:
        assert e["visible"] == (e["from_mode"] in (1, 2))
    # the output changes exactly at visible events
    y = paper_trace.y[:, 0]
    changes = np.nonzero(np.diff(y) != 0)[0]
    t_changes = paper_trace.t[changes + 1]
    t_visible = [e["t"] for e in paper_trace.events if e["visible"]]
    np.testing.assert_array_equal(t_changes, t_visible)
    assert set(np.unique(y)) == {0.0, 2.0}
    server = switching_server()
    assert server.visible_modes == (4,) and server.visible_event_modes == (3, 4)


def test_uniform_grid_samples_lie_on_straight_flows(paper_trace):
    tr = paper_trace
    dt = 0.1
    event_times = {e["t"] for e in tr.events}
    grid = [t for t in tr.t if t not in event_times and 0 < t < tr.t[-1]]
    np.testing.assert_allclose(np.diff(grid)[np.diff(grid) < 1.5 * dt], dt, atol=1e-9)
    # between two consecutive rows the mode is constant and the state moves by f_q * dt
    for k in range(tr.n_samples - 1):
        if tr.t[k + 1] > tr.t[k]:
            assert tr.q[k] == tr.q[k + 1]
            expected = tr.x[k] + (tr.t[k + 1] - tr.t[k]) * paper_trace_f(tr.q[k])
            np.testing.assert_allclose(tr.x[k + 1], expected, atol=1e-9)
    assert np.all(np.diff(tr.t) >= 0)


def paper_trace_f(q: int) -> np.ndarray:
    """Section 5 drift vectors written out for lambda = [1 2 3], mu = [8 10 12]."""
    return {
        1: np.array([-1.0, 1.0, 2.0, 3.0]),
        3: np.array([-1.0, 1.0, 2.0, 3.0]),
        5: np.array([-1.0, 1.0, 2.0, 3.0]),
        2: np.array([0.0, 1.0 - 8.0, 2.0, 3.0]),
        4: np.array([0.0, 1.0, 2.0 - 10.0, 3.0]),
        6: np.array([0.0, 1.0, 2.0, 3.0 - 12.0]),
    }[int(q)]


# ---------------------------------------------------------------------------- the junction's data, the registry


def test_junction_data_are_section_5(junction):
    l1, l2, l3 = LAM
    m1, m2, m3 = MU
    setup = [-1.0, l1, l2, l3]
    np.testing.assert_array_equal(
        junction.f,
        [setup, [0, l1 - m1, l2, l3], setup, [0, l1, l2 - m2, l3], setup, [0, l1, l2, l3 - m3]],
    )
    assert junction.k.tolist() == [1, 2, 1, 3, 1, 4]  # paper's 1-based k_q
    assert junction.alpha.tolist() == [0, GAMMA[1], 0, GAMMA[2], 0, GAMMA[0]]
    assert junction.h.tolist() == [0, 2, 0, 0, 0, 0]
    assert junction.state_names == ("x0", "x1", "x2", "x3")
    assert [junction.successor(q) for q in range(1, 7)] == [2, 3, 4, 5, 6, 1]
    assert junction.mode_duration([0.0, 14.0, 0.0, 0.0], 2) == pytest.approx(2.0)
    with pytest.raises(AttributeError):
        junction.f = np.zeros((6, 4))
    with pytest.raises(ValueError):
        junction.f[0, 0] = 3.0


def test_examples_registered():
    for name, n in (("traffic_junction", 4), ("switching_server", 3)):
        ex = get_example(name)
        assert ex.kind == "constant_drift" and ex.paper == "003"
        assert ex.n_states == n and ex.state_names == ("x0", "x1", "x2", "x3")[:n]
        tr = ex.simulate(t_final=30.0)
        assert isinstance(tr, Trace) and tr.state_names == ex.state_names
        assert tr.t[-1] == 30.0
    tr = get_example("traffic_junction").simulate(t_final=60.0, gamma=(5.0, 10.0, 20.0))
    setup3 = [(s, e) for s, e, m in _mode_intervals(tr) if m == 5]
    assert setup3[0][1] - setup3[0][0] == pytest.approx(20.0)


# ---------------------------------------------------------------------------- bad input


def _raises(field_part: str, **data):
    kwargs = _server_data()
    kwargs.update(data)
    with pytest.raises(ModelError) as exc:
        ConstantDriftSystem(**kwargs)
    assert field_part in exc.value.field, (exc.value.field, str(exc.value))
    return exc.value


def test_valid_server_data_accepted():
    s = ConstantDriftSystem(**_server_data())
    assert s.n_modes == 4 and s.n_buffers == 2


@pytest.mark.parametrize(
    "change, field_part",
    [
        (dict(f=[1.0, 2.0, 3.0]), "f"),
        (dict(f=np.zeros((4, 3, 1))), "f"),
        (dict(f=[[-1.0], [-1.0], [-1.0], [-1.0]]), "f"),
        (dict(trigger=[0, 1, 0]), "trigger"),
        (dict(trigger=[0.0, 1.0, 0.0, 2.0]), "trigger"),
        (dict(trigger=[0, 1, 0, 3]), "trigger (mode 4)"),
        (dict(alpha=[0.0, 1.0, 0.0]), "alpha"),
        (dict(alpha=[0.0, -1.0, 0.0, 2.0]), "alpha (mode 2)"),
        (dict(h=[0, 0, 0]), "h"),
        (dict(h=[0, 0, 2, 4]), "h (mode 3)"),
        (dict(state_names=("a", "b")), "state_names"),
        (dict(mode_names=("m1", "m2", "m3", "m3")), "mode_names"),
    ],
)
def test_bad_shapes_and_values(change, field_part):
    _raises(field_part, **change)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_data(bad):
    f = np.array(_server_data()["f"])
    f[1, 2] = bad
    err = _raises("f", f=f)
    assert "finite" in str(err)
    _raises("alpha", alpha=[0.0, 1.0, 0.0, bad])


def test_assumption_2_1_triggering_component_must_decrease():
    f = np.array(_server_data()["f"])
    f[1, 1] = 0.5  # "serving" type 1 while buffer 1 grows (mu1 < lam1)
    err = _raises("Assumption 2.1 (mode 2)", f=f)
    assert "decrease" in err.expected


def test_assumption_2_1_other_components_must_not_decrease():
    f = np.array(_server_data()["f"])
    f[3, 1] = -0.5
    err = _raises("Assumption 2.1 (mode 4)", f=f)
    assert "x1" in err.expected


def test_assumption_2_2_timer_slope():
    f = np.array(_server_data()["f"])
    f[0, 0] = -2.0
    _raises("Assumption 2.2 (mode 1)", f=f)
    f = np.array(_server_data()["f"])
    f[1, 0] = 0.5
    _raises("Assumption 2.2 (mode 2)", f=f)


def test_assumption_2_3_reset_iff_next_is_timer_mode():
    err = _raises("Assumption 2.3 (mode 2)", alpha=[0.0, 0.0, 0.0, 2.0])
    assert "alpha_q > 0" in err.expected
    err = _raises("Assumption 2.3 (mode 1)", alpha=[1.0, 1.0, 0.0, 2.0])
    assert "alpha_q = 0" in err.expected


def test_assumption_2_4_some_setup_per_cycle():
    with pytest.raises(ModelError) as exc:
        ConstantDriftSystem(f=[[0.0, -1.0, 1.0], [0.0, 1.0, -1.0]], trigger=[1, 2], alpha=[0.0, 0.0], h=[0, 2])
    assert exc.value.field == "Assumption 2.4"


def test_assumption_2_5_setup_followed_by_operation():
    with pytest.raises(ModelError) as exc:
        ConstantDriftSystem(
            f=[[-1.0, 1.0], [-1.0, 1.0], [0.0, -1.0]], trigger=[0, 0, 1], alpha=[1.0, 0.0, 1.0], h=[0, 0, 3]
        )
    assert exc.value.field == "Assumption 2.5 (mode 1)"


def test_assumption_2_6_no_visible_mode():
    err = _raises("Assumption 2.6", h=[0, 0, 0, 0])
    assert "visible" in err.expected


@pytest.mark.parametrize(
    "kwargs, field_part",
    [
        (dict(x0=[5.0, 40.0, 60.0]), "x0"),
        (dict(x0=[5.0, 40.0, np.nan, 0.0]), "x0"),
        (dict(x0=[5.0, 40.0, np.inf, 0.0]), "x0"),
        (dict(x0=[5.0, -1.0, 60.0, 0.0]), "x0[x1]"),
        (dict(x0=[3.0, 40.0, 60.0, 0.0], q0=2), "x0[x0]"),  # Lemma 2.7: no timer outside setup
        (dict(q0=0), "q0"),
        (dict(q0=7), "q0"),
        (dict(q0=1.0), "q0"),
        (dict(t0=10.0, t_final=5.0), "t_final"),
        (dict(t_final=np.nan), "t_final"),
        (dict(dt=0.0), "dt"),
        (dict(dt=-0.1), "dt"),
        (dict(dt=np.inf), "dt"),
    ],
)
def test_simulator_bad_input(junction, kwargs, field_part):
    args = dict(x0=[5.0, 40.0, 60.0, 0.0], q0=1, t0=0.0, t_final=100.0, dt=None)
    args.update(kwargs)
    with pytest.raises(ModelError) as exc:
        simulate_constant_drift(junction, **args)
    assert exc.value.field == field_part, str(exc.value)


def test_simulator_rejects_other_system_types():
    with pytest.raises(ModelError) as exc:
        simulate_constant_drift(_server_data(), [2.0, 1.0, 1.0], 1, 0.0, 10.0)
    assert exc.value.field == "system"


@pytest.mark.parametrize(
    "kwargs, field_part",
    [
        (dict(mu=(8.0, 1.0, 12.0)), "Assumption 2.1 (mode 4)"),  # queue 2 cannot be emptied
        (dict(gamma=(5.0, 0.0, 15.0)), "Assumption 2.3 (mode 2)"),  # zero clearing time
        (dict(mu=(8.0, 10.0)), "mu"),
        (dict(lam=(-1.0, 2.0, 3.0)), "lam[0]"),
        (dict(gamma=(5.0, np.nan, 15.0)), "gamma"),
    ],
)
def test_junction_factory_bad_parameters(kwargs, field_part):
    with pytest.raises(ModelError) as exc:
        traffic_junction(**kwargs)
    assert exc.value.field == field_part, str(exc.value)


@pytest.mark.parametrize(
    "kwargs, field_part",
    [
        (dict(gamma1=0.0), "Assumption 2.3 (mode 4)"),
        (dict(mu1=0.5), "Assumption 2.1 (mode 2)"),
        (dict(lam1=0.0), "lam1"),
        (dict(mu2=np.inf), "mu2"),
    ],
)
def test_server_factory_bad_parameters(kwargs, field_part):
    with pytest.raises(ModelError) as exc:
        switching_server(**kwargs)
    assert exc.value.field == field_part, str(exc.value)


def test_state_helpers_refuse_states_off_their_sets(junction):
    with pytest.raises(ModelError) as exc:
        junction.jump([0.0, 3.0, 0.0, 0.0], 2)  # queue 1 not empty: not on the jump set (3b)
    assert exc.value.field == "x[x1]"
    with pytest.raises(ModelError) as exc:
        junction.flow([0.0, 7.0, 0.0, 0.0], 2, 1.5)  # queue 1 empties after 1 s
    assert exc.value.field == "tau"
    with pytest.raises(ModelError) as exc:
        junction.successor(True)
    assert exc.value.field == "q"
    ev = junction.next_event([0.0, 7.0, 0.0, 0.0], 2)
    assert (ev.dwell, ev.from_mode, ev.to_mode, ev.visible) == (1.0, 2, 3, True)
    np.testing.assert_array_equal(ev.x_plus, [GAMMA[1], 0.0, LAM[1], LAM[2]])
