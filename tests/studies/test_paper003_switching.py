"""Paper 003: the printed matrices of Sections 3 and 5, the gains (20a-b) and the Section 5 run.

Expected values come from the paper (printed matrices of Sections 3 and 5, the gains (20a-b),
the numbers of the Section 5 run, to their printed precision) or from hand computations written
out below with exact fractions; the only other reference is the exact event-time simulator
(unit tests in ``tests/unit/systems/test_constant_drift.py``).  Nothing is compared with a number
produced by the code under test.  The observers on other systems and bad input are unit tests in
``tests/unit/observers/test_drift_observers.py``; ``hybobs observe`` in ``tests/app/test_cli_drift.py``.
"""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest

from hybobs_opt.observers.drift_observer import DriftObserver
from hybobs_opt.synthesis.periodic_gains import analyse_gains, deadbeat_gains, positive_gain_bounds
from hybobs_opt.sim import Trace, simulate_constant_drift
from hybobs_opt.studies import get_example
from hybobs_opt.studies.paper003_switching.scenarios import junction_paper_gains, run_drift_scenario
from hybobs_opt.studies.paper003_switching.systems import (
    JUNCTION_OBSERVER_START,
    JUNCTION_PAPER_VISIBLE_EVENTS,
    JUNCTION_X0_BAR,
    switching_server,
    traffic_junction,
)
from hybobs_opt.systems import ConstantDriftSystem
from hybobs_opt.systems.event_sampled import event_maps, periodic_system

LAM = (1.0, 2.0, 3.0)
MU = (8.0, 10.0, 12.0)
GAMMA = (5.0, 10.0, 15.0)

# switching-server parameters for the symbolic matrices of Section 3 (chosen: the paper keeps them symbolic)
L1_, M1_, M2_, G1_, G2_ = 1.5, 4.0, 5.0, 2.0, 3.0


@pytest.fixture(scope="module")
def junction() -> ConstantDriftSystem:
    return traffic_junction(lam=LAM, mu=MU, gamma=GAMMA)


@pytest.fixture(scope="module")
def server():
    return switching_server(lam1=L1_, mu1=M1_, mu2=M2_, gamma1=G1_, gamma2=G2_)


@pytest.fixture(scope="module")
def paper_trace() -> Trace:
    return get_example("traffic_junction").simulate()


@pytest.fixture(scope="module")
def junction_run():
    return run_drift_scenario("traffic_junction", "paper")


def paper_gains_20():
    """(20a-b) written out for lam = [1 2 3], mu3 = 12: L1 = [0 lam2 lam3], L2 = [lam1 lam2 lam3/mu3 0]."""
    l1, l2, l3 = LAM
    return np.array([[0.0, l2, l3], [l1, l2 * l3 / MU[2], 0.0]])


# ---------------------------------------------------------------------------- Section 3: the switching server
def test_server_all_event_matrices_section_3_1(server):
    l1, m1, m2, g1, g2 = L1_, M1_, M2_, G1_, G2_
    At = {1: [[1, 0, 0], [0, 0, 0], [0, m1 / (m1 - l1), 1]], 2: [[0, 0, 0], [l1, 1, 0], [0, 0, 1]],
          3: [[1, 0, 0], [0, 1, l1 / m2], [0, 0, 0]], 4: [[0, 0, 0], [l1, 1, 0], [0, 0, 1]]}
    at = {1: [0, 0, 0], 2: [0, g2 * l1, 0], 3: [0, 0, 0], 4: [0, g1 * l1, 0]}
    Ct = {1: [0, 1 / (m1 - l1), 0], 2: [1, 0, 0], 3: [0, 0, 1 / m2], 4: [1, 0, 0]}
    ct = {1: 0.0, 2: g2, 3: 0.0, 4: g1}
    maps = event_maps(server)
    for q in range(1, 5):
        np.testing.assert_allclose(maps.A_tilde[q - 1], At[q], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(maps.a_tilde[q - 1], at[q], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(maps.C_tilde[q - 1], Ct[q], rtol=1e-14, atol=1e-14)
        assert maps.c_tilde[q - 1] == pytest.approx(ct[q], abs=1e-14)
    # Remark 3.1: all non-negative
    assert (maps.A_tilde >= 0).all() and (maps.a_tilde >= 0).all() and (maps.C_tilde >= 0).all()


def test_server_reduced_matrices_section_3_2(server):
    l1, m1, m2, g1, g2 = L1_, M1_, M2_, G1_, G2_
    Ab = {1: [[0, 0], [m1 / (m1 - l1), 1]], 2: np.eye(2), 3: [[1, l1 / m2], [0, 0]], 4: np.eye(2)}
    ab = {1: [0, 0], 2: [g2 * l1, 0], 3: [0, 0], 4: [g1 * l1, 0]}
    Cb = {1: [1 / (m1 - l1), 0], 2: [0, 0], 3: [0, 1 / m2], 4: [0, 0]}
    cb = {1: 0.0, 2: g2, 3: 0.0, 4: g1}
    maps = event_maps(server)
    for q in range(1, 5):
        np.testing.assert_allclose(maps.A_bar[q - 1], Ab[q], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(maps.a_bar[q - 1], ab[q], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(maps.C_bar[q - 1], Cb[q], rtol=1e-14, atol=1e-14)
        assert maps.c_bar[q - 1] == pytest.approx(cb[q], abs=1e-14)


def test_server_event_sampled_matrices_of_section_3_2():
    # Section 3.2: x_bar(t_{k+1}) = A_bar_q x_bar(t_k) + a_bar_q, t_{k+1} = t_k + C_bar_q x_bar(t_k)
    # + c_bar_q with q the mode left at t_k; matrices printed for the switching server.
    lam1, mu1, mu2, g1, g2 = 1.5, 4.0, 5.0, 2.0, 3.0
    A = {
        1: np.array([[0, 0], [mu1 / (mu1 - lam1), 1]]),
        2: np.eye(2),
        3: np.array([[1, lam1 / mu2], [0, 0]]),
        4: np.eye(2),
    }
    a = {1: [0, 0], 2: [g2 * lam1, 0], 3: [0, 0], 4: [g1 * lam1, 0]}
    C = {1: [1 / (mu1 - lam1), 0], 2: [0, 0], 3: [0, 1 / mu2], 4: [0, 0]}
    c = {1: 0.0, 2: g2, 3: 0.0, 4: g1}
    sys_ = switching_server(lam1=lam1, mu1=mu1, mu2=mu2, gamma1=g1, gamma2=g2)
    tr = simulate_constant_drift(sys_, [g1, 7.0, 3.0], 1, 0.0, 80.0)
    assert len(tr.events) > 12
    for prev, nxt in zip(tr.events[:-1], tr.events[1:]):
        q = prev["from_mode"]
        xb = np.asarray(prev["x"])[1:]
        np.testing.assert_allclose(np.asarray(nxt["x"])[1:], A[q] @ xb + a[q], rtol=1e-12, atol=1e-12)
        assert nxt["t"] - prev["t"] == pytest.approx(np.dot(C[q], xb) + c[q], abs=1e-12)


def test_server_two_periodic_system_section_3_3(server):
    l1, m1, m2, g1, g2 = L1_, M1_, M2_, G1_, G2_
    ps = periodic_system(server)
    assert ps.period == 2 and ps.event_modes == (3, 4) and ps.visible_modes == (4,)
    np.testing.assert_allclose(ps.A[0], [[1, l1 / m2], [0, 0]], rtol=1e-14)
    np.testing.assert_allclose(ps.a[0], [0, 0], atol=1e-14)
    np.testing.assert_allclose(ps.C[0], [0, 1 / m2], rtol=1e-14)
    assert ps.c[0] == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(ps.A[1], [[0, 0], [m1 / (m1 - l1), 1]], rtol=1e-14)
    np.testing.assert_allclose(ps.a[1], [g2 * l1, l1 * m1 * g1 / (m1 - l1)], rtol=1e-14)
    np.testing.assert_allclose(ps.C[1], [1 / (m1 - l1), 0], rtol=1e-14)
    assert ps.c[1] == pytest.approx(g1 * m1 / (m1 - l1) + g2, rel=1e-14)
    assert ps.segments == ((3,), (4, 1, 2))


# ---------------------------------------------------------------------------- Section 5: the T-junction's matrices and gains (20)
def test_junction_periodic_system_section_5(junction):
    l1, l2, l3 = LAM
    m1, m2, m3 = MU
    d = (m2 - l2) * (m3 - l3)
    ps = periodic_system(junction)
    assert ps.event_modes == (1, 2)
    np.testing.assert_allclose(ps.A[0], [[0, 0, 0], [l2 / (m1 - l1), 1, 0], [l3 / (m1 - l1), 0, 1]], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ps.C[0], [1 / (m1 - l1), 0, 0], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ps.A[1], [[1, l1 * m3 / d, l1 / (m3 - l3)], [0, l2 * l3 / d, l2 / (m3 - l3)], [0, 0, 0]],
                               rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ps.C[1], [0, m3 / d, 1 / (m3 - l3)], rtol=1e-14, atol=1e-15)


def test_junction_visible_sampled_matrices_of_section_5(junction):
    # Section 5 prints A1, C1 (entering "serve flow 1" -> leaving it) and A2, C2 (leaving it ->
    # entering it again) of the visible-event sampled system (14); a_j, c_j are omitted there, so
    # check the linear parts with differences of two trajectories.
    l1, l2, l3 = LAM
    m1, m2, m3 = MU
    A1 = np.array([[0, 0, 0], [l2 / (m1 - l1), 1, 0], [l3 / (m1 - l1), 0, 1]])
    C1 = np.array([1 / (m1 - l1), 0, 0])
    d = (m2 - l2) * (m3 - l3)
    A2 = np.array([[1, l1 * m3 / d, l1 / (m3 - l3)], [0, l2 * l3 / d, l2 / (m3 - l3)], [0, 0, 0]])
    C2 = np.array([0, m3 / d, 1 / (m3 - l3)])

    def visible_pair(x_bar, q0):
        x0 = 0.0 if q0 == 2 else GAMMA[1]  # q0 = 2: entered serve 1; q0 = 3: just left it
        tr = simulate_constant_drift(junction, [x0, *x_bar], q0, 0.0, 200.0)
        e = next(e for e in tr.events if e["visible"])
        return e["t"], np.asarray(e["x"])[1:]

    base, delta = np.array([30.0, 20.0, 15.0]), np.array([4.0, 3.0, 2.0])
    t_a, x_a = visible_pair(base, 2)
    t_b, x_b = visible_pair(base + delta, 2)
    np.testing.assert_allclose(x_b - x_a, A1 @ delta, atol=1e-9)
    assert t_b - t_a == pytest.approx(C1 @ delta, abs=1e-9)

    base = np.array([0.0, 50.0, 40.0])
    delta = np.array([0.0, 6.0, 5.0])  # x1 = 0 when serving flow 1 ends
    t_a, x_a = visible_pair(base, 3)
    t_b, x_b = visible_pair(base + delta, 3)
    np.testing.assert_allclose(x_b - x_a, A2 @ delta, atol=1e-9)
    assert t_b - t_a == pytest.approx(C2 @ delta, abs=1e-9)


def test_sequential_deadbeat_reproduces_gains_20(junction):
    ps = periodic_system(junction)
    g = deadbeat_gains(ps)
    np.testing.assert_allclose(g.L, paper_gains_20(), rtol=1e-12, atol=1e-12)
    assert g.deadbeat and g.positive
    np.testing.assert_allclose(junction_paper_gains(LAM, MU), paper_gains_20(), rtol=0, atol=0)


def test_paper_gains_20_are_positive_and_deadbeat(junction):
    # By hand from the Section 5 matrices: A1 - L1 C1 = diag(0, 1, 1) and
    # A2 - L2 C2 = [[1, 0, 0], [0, 0, lam2/mu3], [0, 0, 0]]; both products of the two are
    # [[0,0,0],[0,0,lam2/mu3],[0,0,0]], whose square is 0: deadbeat after two periods (4 events).
    ps = periodic_system(junction)
    g = analyse_gains(ps, paper_gains_20())
    np.testing.assert_allclose(g.closed_loop[0], np.diag([0.0, 1.0, 1.0]), atol=1e-15)
    np.testing.assert_allclose(g.closed_loop[1], [[1, 0, 0], [0, 0, LAM[1] / MU[2]], [0, 0, 0]], atol=1e-15)
    assert g.positive  # "the matrices A_v - L_v C_v and L_v C_v are positive" (Section 5)
    assert g.deadbeat_steps == 4
    assert g.monodromy_radius == pytest.approx(0.0, abs=1e-12)
    # (20a-b) is the corner of the box of positive gains (see hybobs_opt.synthesis.periodic_gains)
    np.testing.assert_allclose(positive_gain_bounds(ps), paper_gains_20(), rtol=1e-14, atol=1e-15)


# ---------------------------------------------------------------------------- Section 5 run: the plant
def test_paper_visible_events_at_70_7_79_2_140_3(paper_trace):
    # Section 5: after the observer starts at t = 50 the true junction starts serving flow 1 at
    # 70.7, empties queue 1 at 79.2 and starts serving flow 1 again at 140.3 (printed to 0.1 s).
    after = [e for e in paper_trace.events if e["visible"] and e["t"] > JUNCTION_OBSERVER_START]
    times = [e["t"] for e in after[:3]]
    for got, printed in zip(times, JUNCTION_PAPER_VISIBLE_EVENTS):
        assert abs(got - printed) < 0.05, (times, JUNCTION_PAPER_VISIBLE_EVENTS)
    assert [(e["from_mode"], e["to_mode"]) for e in after[:3]] == [(1, 2), (2, 3), (1, 2)]
    assert JUNCTION_PAPER_VISIBLE_EVENTS == (70.7, 79.2, 140.3)
    # y(50) = y_hat(50) = 0 in the paper: the true system is not serving flow 1 at t = 50.
    k50 = np.searchsorted(paper_trace.t, JUNCTION_OBSERVER_START)
    assert paper_trace.y[k50, 0] == 0


def test_paper_scenario_initial_state_is_documented_one(paper_trace):
    assert paper_trace.t[0] == 0.0 and paper_trace.q[0] == 1
    np.testing.assert_array_equal(paper_trace.x[0], [GAMMA[0], *JUNCTION_X0_BAR])


def test_paper_narrative_true_queue2_larger_than_estimate(paper_trace):
    # Section 5: at 79.2 the estimate of queue 2 is too small, x2_hat(79.2+) = 52.8 + lam2*(79.2 -
    # 70.7) = 69.8 (paper's printed numbers), so the true next event comes after the predicted
    # 137; the delay is C2 (x - x_hat) = mu3 / ((mu2 - lam2)(mu3 - lam3)) * (x2 - x2_hat) = 3.3 s.
    ev = [e for e in paper_trace.events if e["visible"] and e["t"] > 50][1]
    x2_hat = 52.8 + LAM[1] * (79.2 - 70.7)
    assert ev["x"][2] > x2_hat
    delay = MU[2] / ((MU[1] - LAM[1]) * (MU[2] - LAM[2])) * (ev["x"][2] - x2_hat)
    assert abs((137.0 + delay) - 140.3) < 0.1


# ---------------------------------------------------------------------------- Section 5 run: the observer
def _hand_prediction():
    """Open-loop flow from x^(50) = [0, 70, 20, 30] in mode 4, with exact fractions (Section 5 data)."""
    l1, l2, l3 = (F(int(v)) for v in LAM)
    m2, m3 = F(10), F(12)
    g1, g3 = F(5), F(15)
    t, x1, x2, x3 = F(50), F(70), F(20), F(30)
    d = x2 / (m2 - l2)  # mode 4: serve flow 2 until empty
    t, x1, x2, x3 = t + d, x1 + l1 * d, F(0), x3 + l3 * d
    d = g3  # mode 5: clear for flow 3
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    d = x3 / (m3 - l3)  # mode 6: serve flow 3 until empty
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, F(0)
    d = g1  # mode 1: clear for flow 1; its end is the predicted visible event
    t, x1, x2, x3 = t + d, x1 + l1 * d, x2 + l2 * d, x3 + l3 * d
    assert (t, x1, x2, x3) == (F(245, 3), F(305, 3), F(175, 3), F(15))
    return t, (x1, x2, x3)


def test_first_visible_event_predicted_at_81_7(junction_run):
    ev = junction_run["observer"].events[0]
    t_hand, x_hand = _hand_prediction()
    assert abs(ev.predicted_t - 81.7) < 0.05  # paper: "predicted at t~ = 81.7"
    np.testing.assert_allclose(ev.x_predicted, [101.7, 58.3, 15.0], atol=0.05)  # x~(t~) = [101.7 58.3 15]
    assert ev.predicted_t == pytest.approx(float(t_hand), rel=1e-12)
    np.testing.assert_allclose(ev.x_predicted, [float(v) for v in x_hand], rtol=1e-12)


def test_jump_at_70_7(junction_run):
    ev = junction_run["observer"].events[0]
    assert abs(ev.t - 70.7) < 0.05 and ev.kind == "18d" and not ev.waited
    assert (ev.mode_left, ev.mode_entered) == (1, 2)  # "the estimated mode changes to serving flow 1"
    # The paper applied (18d) to its rounded numbers: 101.7 + 1 (70.7 - 81.7) = 90.7 and
    # 58.3 + 0.5 (70.7 - 81.7) = 52.8 -- the gain L2 = [1, 0.5, 0] of (20b) reproduces the print:
    assert round(101.7 + 1.0 * (70.7 - 81.7), 6) == 90.7 and round(58.3 + 0.5 * (70.7 - 81.7), 6) == 52.8
    # Unrounded (t = 495/7, the simulator's event, hand-checked in test_constant_drift.py):
    t_ev = F(495, 7)
    t_hand, (x1, x2, x3) = _hand_prediction()
    exact = [float(x1 + (t_ev - t_hand)), float(x2 + F(1, 2) * (t_ev - t_hand)), float(x3)]
    assert ev.t == pytest.approx(float(t_ev), rel=1e-12)
    np.testing.assert_allclose(ev.x_after[1:], exact, rtol=1e-12)
    # within the printed precision, propagated: x2 carries 0.05 + 0.5 * (0.05 + 0.05)
    assert abs(ev.x_after[1] - 90.7) < 0.05 + 1.0 * 0.1
    assert abs(ev.x_after[2] - 52.8) < 0.05 + 0.5 * 0.1
    assert ev.x_after[3] == pytest.approx(15.0, abs=1e-12)
    assert ev.x_after[0] == 0.0  # alpha_1 = 0: serving starts at once


def test_second_event_79_2_and_waiting_until_140_3(junction_run):
    obs, trace = junction_run["observer"], junction_run["trace"]
    e2, e3 = obs.events[1], obs.events[2]
    assert abs(e2.t - 79.2) < 0.05 and e2.kind == "18e" and (e2.mode_left, e2.mode_entered) == (2, 3)
    assert e2.x_after[1] == 0.0  # "jump (18e) results in x1^(79.2+) = 0"
    assert e2.x_after[0] == GAMMA[1]  # the clearing time of flow 2 starts
    x_true = trace.x[np.nonzero(trace.t == e2.t)[0][-1]]
    assert e2.x_after[3] == pytest.approx(x_true[3], rel=1e-12)  # "x1^ and x3^ correctly estimated"
    assert e2.x_after[2] < x_true[2]  # "x2^(79.2+) < x2(79.2+)": the next event comes later
    assert abs(e3.predicted_t - 137.0) < 0.05  # "the observer predicts the next visible event at 137"
    assert e3.waited and abs(e3.t - 140.3) < 0.05
    # exact reconstruction at 140.3 (deadbeat)
    x_true = trace.x[np.nonzero(trace.t == e3.t)[0][-1]]
    np.testing.assert_allclose(e3.x_after, x_true, rtol=1e-12, atol=1e-10)
    # afterwards the estimate follows the truth exactly
    np.testing.assert_allclose(junction_run["out"].x_hat[-1], junction_run["x_true"][-1], atol=1e-9)


def test_x1_hat_zero_after_79_2_and_waiting_mode(junction):
    # event-driven API on the true event log: x1^ stays 0 while flow 1 is not served, and the
    # observer sits in the waiting mode 1 + 1/2 between the predicted 137 and the actual 140.3.
    tr = run_drift_scenario("traffic_junction", "paper")["trace"]
    obs = DriftObserver(junction, paper_gains_20())
    obs.reset([0.0, 70.0, 20.0, 30.0], t0=50.0, q0=4)
    log = [e for e in tr.events if e["visible"] and e["t"] > 50.0]
    run = obs.observe_events(log[:3], grid=[75.0, 85.0, 100.0, 120.0, 136.0, 138.0, 140.0])
    at = {float(t): (x, q, w) for t, x, q, w in zip(run.t, run.x_hat, run.mode, run.waiting)}
    for t in (85.0, 100.0):
        assert at[t][0][1] == pytest.approx(LAM[0] * (t - obs.events[1].t), abs=1e-9)  # only arrivals
    assert not at[136.0][2] and at[138.0][2] and at[140.0][2] and at[138.0][1] == 1
    # waiting drift (18b): [0; L2] = [0; 1, 0.5, 0]
    np.testing.assert_allclose(at[140.0][0] - at[138.0][0], [0.0, 2.0, 1.0, 0.0], atol=1e-9)
    assert [r.t for r in run.events] == [r.t for r in obs.events]
    ref = run_drift_scenario("traffic_junction", "paper")["observer"].events
    for a, b in zip(run.events, ref[:3]):
        np.testing.assert_allclose(a.x_after, b.x_after, rtol=1e-12, atol=1e-12)
