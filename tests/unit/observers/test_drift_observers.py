"""Event-sampled models and observers of constant-drift hybrid systems (paper 003, Sections 3-5).

Expected values come from the paper (printed matrices of Sections 3 and 5, the gains (20a-b),
the numbers of the Section 5 run, to their printed precision) or from hand computations written
out below with exact fractions; the only other reference is the exact event-time simulator
(tested in test_constant_drift.py).  Nothing is compared with a number produced by the code
under test.
"""

from __future__ import annotations

import argparse
import json
from fractions import Fraction as F

import numpy as np
import pytest

from hybobs_opt.errors import InfeasibleError, ModelError
from hybobs_opt.examples.switching import switching_server, traffic_junction
from hybobs_opt.observers.base import FALLBACK, OBSERVABLE
from hybobs_opt.observers.drift_observer import DriftObserver, junction_paper_gains, run_drift_scenario
from hybobs_opt.observers.periodic import (
    CopositiveCertificate,
    NoDeadbeatCertificate,
    PerronCertificate,
    PeriodicObserver,
    analyse_gains,
    deadbeat_gains,
    positive_deadbeat_gains,
    positive_gain_bounds,
    positive_observer,
)
from hybobs_opt.report.drift_section import polling_server, unserved_buffer_server, visible_samples
from hybobs_opt.sim import simulate_constant_drift
from hybobs_opt.systems import ConstantDriftSystem
from hybobs_opt.systems.event_sampled import PeriodicSystem, event_maps, periodic_system

LAM = (1.0, 2.0, 3.0)
MU = (8.0, 10.0, 12.0)
GAMMA = (5.0, 10.0, 15.0)

# switching-server parameters for the symbolic matrices of Section 3 (chosen: the paper keeps them symbolic)
L1_, M1_, M2_, G1_, G2_ = 1.5, 4.0, 5.0, 2.0, 3.0


@pytest.fixture(scope="module")
def junction():
    return traffic_junction(lam=LAM, mu=MU, gamma=GAMMA)


@pytest.fixture(scope="module")
def junction_run():
    return run_drift_scenario("traffic_junction", "paper")


@pytest.fixture(scope="module")
def server():
    return switching_server(lam1=L1_, mu1=M1_, mu2=M2_, gamma1=G1_, gamma2=G2_)


def paper_gains_20():
    """(20a-b) written out for lam = [1 2 3], mu3 = 12: L1 = [0 lam2 lam3], L2 = [lam1 lam2 lam3/mu3 0]."""
    l1, l2, l3 = LAM
    return np.array([[0.0, l2, l3], [l1, l2 * l3 / MU[2], 0.0]])


# ---------------------------------------------------------------------------- Section 3: matrices
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


@pytest.mark.parametrize(
    "factory, visible, V",
    [
        ("junction", None, (1, 2)),
        ("junction", (4,), (3, 4)),  # a sensor on lane 2 instead
        ("junction", (1, 3), (1, 2, 3, 6)),  # two visible setups: V = Q_v plus their predecessors
        ("server", (2,), (1, 2)),
        ("server", None, (3, 4)),
    ],
)
def test_periodic_system_matches_exact_simulation(factory, visible, V, junction, server):
    # eq. (14) for any set of visible modes: stepping it from the true state at a visible event
    # gives the simulator's next visible event (state and time).
    system = junction if factory == "junction" else server
    ps = periodic_system(system, visible)
    assert ps.event_modes == V
    x0 = [system.alpha[-1]] + [30.0, 12.0, 7.0][: system.n_buffers]
    tr = simulate_constant_drift(system, x0, 1, 0.0, 400.0)
    evs = [e for e in tr.events if e["from_mode"] in V]
    assert len(evs) > 8
    for a, b in zip(evs[:-1], evs[1:]):
        j = ps.phase_of(a["from_mode"])
        assert b["from_mode"] == V[j % len(V)]
        x_next, dt = ps.step(j, np.asarray(a["x"])[1:])
        np.testing.assert_allclose(x_next, np.asarray(b["x"])[1:], rtol=1e-11, atol=1e-9)
        assert dt == pytest.approx(b["t"] - a["t"], rel=1e-11, abs=1e-9)


# ---------------------------------------------------------------------------- gains
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
    # (20a-b) is the corner of the box of positive gains (see hybobs_opt.observers.periodic)
    np.testing.assert_allclose(positive_gain_bounds(ps), paper_gains_20(), rtol=1e-14, atol=1e-15)


def test_server_deadbeat_gains_by_hand(server):
    # From the Section 3.3 matrices: L1 = [lam1, 0] gives A1 - L1 C1 = [[1, 0], [0, 0]],
    # L2 = [0, mu1] gives A2 - L2 C2 = [[0, 0], [0, 1]]; their product is 0 (deadbeat in 2 events).
    ps = periodic_system(server)
    g = deadbeat_gains(ps)
    np.testing.assert_allclose(g.L, [[L1_, 0.0], [0.0, M1_]], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(g.closed_loop[0], [[1, 0], [0, 0]], atol=1e-14)
    np.testing.assert_allclose(g.closed_loop[1], [[0, 0], [0, 1]], atol=1e-14)
    assert g.deadbeat_steps == 2 and g.positive


def test_positive_lp_for_junction(junction):
    ps = periodic_system(junction)
    g = positive_observer(ps)
    U = paper_gains_20()
    assert g.status == "optimal" and g.positive and g.rate < 1.0
    assert np.all(g.L >= 0.0) and np.all(g.L <= U + 1e-12)
    cert = g.certificate
    assert isinstance(cert, CopositiveCertificate) and cert.verify()
    # the certificate means what it says: V_j(e) = p_j^T |e| contracts along (16)'s error
    e = np.array([30.0, -20.0, 5.0])
    for j in range(6):
        jj = j % 2
        e_next = g.closed_loop[jj] @ e
        assert cert.p[(jj + 1) % 2] @ np.abs(e_next) <= cert.rate * (cert.p[jj] @ np.abs(e)) + 1e-9
        e = e_next
    # a tampered certificate fails the numpy re-check
    assert not CopositiveCertificate(cert.A, cert.C, cert.L, cert.p, 0.5 * cert.rate).verify()
    # (p_2^T M_1)_2 = p_2[1] must stay below rate * p_1[1] since M_1 = diag(0, 1, 1)
    assert not CopositiveCertificate(cert.A, cert.C, cert.L, cert.p * np.array([[1.0, 1.0, 1.0], [1.0, 1e3, 1.0]]),
                                     cert.rate).verify()


def test_positive_observer_estimates_stay_nonnegative():
    res = run_drift_scenario("traffic_junction", "positive")
    assert res["summary"]["nonnegative"] and res["out"].x_hat[:, 1:].min() >= 0.0
    assert np.max(np.abs(res["summary"]["final_error"])) < 1e-6
    # and on the polling server, where the deadbeat gains drive an estimate negative
    system = polling_server()
    ps = periodic_system(system)
    tr = simulate_constant_drift(system, [0.0, 20.0, 10.0], 2, 0.0, 300.0, dt=0.25)
    mins = {}
    for label, gains in (("deadbeat", deadbeat_gains(ps)), ("positive", positive_observer(ps))):
        obs = DriftObserver(system, gains)
        # a grossly overestimated buffer 1 while (the observer thinks) it is served slowly: the first
        # visible event (t = 2.5) comes 107.8 s early and a gain on x2 pulls x2^ below zero
        obs.reset([0.0, 300.0, 0.0], t0=0.0, mode=4)
        out = obs.run_trace(tr)
        mins[label] = out.x_hat[:, 1:].min()
        assert np.max(np.abs(out.x_hat[-1] - tr.x[-1])) < 1e-6 * (1 + np.abs(tr.x[-1]).max())
    assert mins["deadbeat"] < -1.0 and mins["positive"] >= 0.0
    # Remark 4.4: the projected deadbeat estimate is non-negative and still converges
    obs = DriftObserver(system, deadbeat_gains(ps), project=True)
    obs.reset([0.0, 300.0, 0.0], t0=0.0, mode=4)
    out = obs.run_trace(tr)
    assert out.x_hat[:, 1:].min() >= 0.0
    assert np.max(np.abs(out.x_hat[-1] - tr.x[-1])) < 1e-6 * (1 + np.abs(tr.x[-1]).max())


def test_no_positive_gain_gets_an_infeasibility_report():
    # Observable (deadbeat gains exist) but no positive gain converges: A = [[1,1],[0,1]], C = [1, 0].
    # Positive gains satisfy 0 <= L <= [1, 0]; at the corner A - L C = [[0,1],[0,1]] has eigenvalue 1.
    ps = PeriodicSystem(A=[[[1.0, 1.0], [0.0, 1.0]]], a=[[0.0, 0.0]], C=[[1.0, 0.0]], c=[0.0], event_modes=(1,),
                        segments=((1,),), visible_modes=(1,))
    g = deadbeat_gains(ps)
    assert g.deadbeat and not g.positive
    with pytest.raises(InfeasibleError) as exc:
        positive_observer(ps)
    cert = exc.value.certificate
    assert isinstance(cert, PerronCertificate) and cert.verify()
    assert cert.r >= 1.0 - 1e-9 and "no positive gain gives a convergent observer" in str(exc.value)
    forged = PerronCertificate(cert.A, cert.C, cert.start, np.array([1.0, 0.0]), cert.r, 1.0)
    assert not forged.verify()  # Phi(U) e1 = 0: not a witness


def test_polling_server_positive_but_not_deadbeat():
    ps = periodic_system(polling_server())
    g = deadbeat_gains(ps)
    assert g.deadbeat and not g.positive
    with pytest.raises(InfeasibleError) as exc:
        positive_deadbeat_gains(ps)
    assert isinstance(exc.value.certificate, PerronCertificate) and exc.value.certificate.verify()
    assert "deadbeat" in exc.value.certificate.reason
    pos = positive_observer(ps)
    assert pos.positive and pos.certificate.verify() and not pos.deadbeat and pos.monodromy_radius < 1.0


def test_unserved_buffer_has_no_observer_at_all():
    ps = periodic_system(unserved_buffer_server())
    with pytest.raises(InfeasibleError) as exc:
        deadbeat_gains(ps)
    assert isinstance(exc.value.certificate, NoDeadbeatCertificate) and exc.value.certificate.verify()
    with pytest.raises(InfeasibleError) as exc:
        positive_observer(ps)
    assert isinstance(exc.value.certificate, PerronCertificate) and exc.value.certificate.verify()


# ---------------------------------------------------------------------------- Section 5 run
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
    obs.reset([0.0, 70.0, 20.0, 30.0], t0=50.0, mode=4)
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


def test_server_observer_exact_after_two_visible_events():
    res = run_drift_scenario("switching_server", "deadbeat")
    evs, tr = res["observer"].events, res["trace"]
    assert len(evs) >= 4
    for k, e in enumerate(evs):
        x_true = tr.x[np.nonzero(tr.t == e.t)[0][-1]]
        # deadbeat in 2 events after the first update guarantees k >= 2; k = 1 is exact too because
        # buffer 1 is emptied (mode 2) before the first visible event in the plant and the observer,
        # so the first error is [0, e2], which A_1 - L_1 C_1 = diag(1, 0) removes.
        if k >= 1:
            np.testing.assert_allclose(e.x_after, x_true, rtol=1e-12, atol=1e-10)
    assert res["summary"]["nonnegative"]
    flags = res["out"].flags
    assert (flags == OBSERVABLE).any()


def test_periodic_observer_error_recursion(junction):
    # observer (16) on the true visible events: e_{j+1} = (A_j - L_j C_j) e_j, zero after 4 events
    ps = periodic_system(junction)
    tr = simulate_constant_drift(junction, [5.0, 40.0, 60.0, 0.0], 1, 0.0, 600.0)
    t, v, x = visible_samples(tr, ps)
    L = paper_gains_20()
    obs = PeriodicObserver(ps, L)
    xh = np.array([10.0, 90.0, 0.0])
    obs.reset(xh, t0=t[1], mode=int(v[1]))
    e = x[1] - xh
    for k in range(2, 8):
        j = ps.phase_of(int(v[k - 1]))
        e = (ps.A[j - 1] - np.outer(L[j - 1], ps.C[j - 1])) @ e
        est = obs.step([t[k]], [v[k]])
        np.testing.assert_allclose(x[k] - est.x, e, atol=1e-9)
        if k - 1 >= 4:
            assert np.max(np.abs(x[k] - est.x)) < 1e-9 and est.flag == OBSERVABLE


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "data, field",
    [
        (dict(f=[[-1.0, 1.0, 0.5], [0.0, 0.5, 0.5]], trigger=[0, 1], alpha=[0.0, 2.0], h=[0, 2]), "Assumption 2.1 (mode 2)"),
        (dict(f=[[-2.0, 1.0, 0.5], [0.0, -3.0, 0.5]], trigger=[0, 1], alpha=[0.0, 2.0], h=[0, 2]), "Assumption 2.2 (mode 1)"),
        (dict(f=[[-1.0, 1.0, 0.5], [0.0, -3.0, 0.5]], trigger=[0, 1], alpha=[0.0, 0.0], h=[0, 2]), "Assumption 2.3 (mode 2)"),
        (dict(f=[[0.0, -1.0, 1.0], [0.0, 1.0, -1.0]], trigger=[1, 2], alpha=[0.0, 0.0], h=[0, 2]), "Assumption 2.4"),
        (dict(f=[[-1.0, 1.0], [-1.0, 1.0], [0.0, -1.0]], trigger=[0, 0, 1], alpha=[1.0, 0.0, 1.0], h=[0, 0, 3]), "Assumption 2.5 (mode 1)"),
        (dict(f=[[-1.0, 1.0, 0.5], [0.0, -3.0, 0.5]], trigger=[0, 1], alpha=[0.0, 2.0], h=[0, 0]), "Assumption 2.6"),
    ],
)
def test_systems_violating_assumptions_are_refused(data, field):
    with pytest.raises(ModelError) as exc:
        DriftObserver(ConstantDriftSystem(**data))
    assert exc.value.field == field


def test_bad_model_arguments(junction):
    with pytest.raises(ModelError) as exc:
        periodic_system(junction, visible_modes=())
    assert exc.value.field == "Assumption 2.6"
    with pytest.raises(ModelError) as exc:
        periodic_system(junction, visible_modes=(7,))
    assert exc.value.field == "visible_modes"
    with pytest.raises(ModelError) as exc:
        periodic_system("junction")
    assert exc.value.field == "system"
    with pytest.raises(ModelError) as exc:
        DriftObserver(junction, np.zeros((3, 3)))
    assert exc.value.field == "gains"
    obs = DriftObserver(junction, paper_gains_20())
    for kwargs, field in ((dict(x0=[0.0, -1.0, 2.0, 3.0], mode=4), "x0[x1]"), (dict(x0=[3.0, 1.0, 2.0, 3.0], mode=4), "x0[x0]"),
                          (dict(x0=[0.0, 1.0, 2.0], mode=4), "x0"), (dict(mode=9), "mode"), (dict(t0=np.nan), "t0")):
        with pytest.raises(ModelError) as exc:
            obs.reset(**kwargs)
        assert exc.value.field == field
    ps = periodic_system(junction)
    with pytest.raises(ModelError) as exc:
        positive_observer(ps, rate=1.5)
    assert exc.value.field == "rate"
    neg = PeriodicSystem(A=[[[1.0, -1.0], [0.0, 1.0]]], a=[[0.0, 0.0]], C=[[1.0, 0.0]], c=[0.0], event_modes=(1,),
                         segments=((1,),), visible_modes=(1,))
    with pytest.raises(ModelError) as exc:
        positive_gain_bounds(neg)
    assert exc.value.field == "A"
    with pytest.raises(ModelError) as exc:
        obs.observe_events([(60.0, 2), (55.0, 0)])
    assert exc.value.field == "events[1].t"


def test_bad_samples_fall_back_without_raising(junction):
    obs = DriftObserver(junction, paper_gains_20())
    obs.reset([0.0, 70.0, 20.0, 30.0], t0=50.0, mode=4)
    assert obs.step([50.0], [0]).flag != FALLBACK
    x_open = obs.step([55.0], [0]).x
    for u, y in (([56.0], [np.nan]), ([57.0], [5]), ([57.5], [0.5]), ([52.0], [0]), ([58.0], [0, 0]), ("abc", [0]),
                 ([np.inf], [0])):
        e = obs.step(u, y)
        assert e.flag == FALLBACK and "reason" in e.info
    # the fallbacks predicted open loop: the estimate at 58 is the model flow from 55
    e = obs.step([58.0], [0])
    assert e.flag != FALLBACK
    # from t = 50 in mode 4 queue 2 empties at 52.5; the clearing for flow 3 (mode 5, drift f_5) lasts to 67.5
    np.testing.assert_allclose(e.x, x_open + 3.0 * np.array([-1.0, *LAM]), atol=1e-9)
    po = PeriodicObserver(periodic_system(junction), paper_gains_20())
    po.reset([1.0, 2.0, 3.0], t0=10.0, mode=1)
    assert po.step([20.0], [6]).flag == FALLBACK and po.step([5.0], [2]).flag == FALLBACK


def test_initial_mode_mismatch_then_resync(junction):
    # started in the wrong mode (3, clearing for flow 2) while the junction serves flow 1 (y = 2):
    # the first sample is flagged, the end of serving flow 1 (79.2) is not the visible event the
    # observer expects (entering serve 1), so it resynchronises; later events are regular (18d-e)
    # and the deadbeat gains make the estimate exact.
    from hybobs_opt.examples.switching import traffic_junction_scenario

    tr = traffic_junction_scenario(junction, t_final=300.0)
    obs = DriftObserver(junction, paper_gains_20())
    obs.reset([GAMMA[1], 0.0, 50.0, 50.0], t0=75.0, mode=3)
    keep = tr.t >= 75.0
    out = obs.run(tr.t[keep], tr.y[keep, 0])
    assert out.flags[0] == FALLBACK
    kinds = [r.kind for r in obs.events]
    assert kinds[0] == "resync" and kinds[1:5] == ["18d", "18e"] * 2 and len(kinds) >= 5
    assert abs(obs.events[0].t - 79.2) < 0.05 and obs.events[0].x_after[0] == GAMMA[1]
    # four regular updates after the resync: exact (deadbeat index 4), flagged observable from the fifth
    np.testing.assert_allclose(out.x_hat[-1], tr.x[-1], atol=1e-9)


def test_report_section_builds(tmp_path):
    from hybobs_opt.report.drift_section import drift_section

    sec = drift_section(tmp_path, lambda msg: None)
    assert (tmp_path / "drift_junction.png").read_bytes()[:4] == b"\x89PNG"
    cmp_ = sec.summary["comparison"]
    lookup = cmp_["traffic_junction"]["observers"]["lookup table (paper 002)"]
    assert lookup["applies"] and lookup["horizon_T"] == 4
    polling = cmp_["polling_server"]["observers"]
    assert polling["sequential deadbeat"]["min_estimate"] < 0.0 <= polling["positive LP"]["min_estimate"]
    assert all(rec["verified"] for rec in sec.summary["infeasible"])


# ---------------------------------------------------------------------------- CLI
def test_observe_json_scenario(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "traffic_junction", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    evs = out["visible_events"]
    assert [round(e["t"], 1) for e in evs[:3]] == [70.7, 79.2, 140.3]
    assert [round(evs[k]["predicted_t"], 1) for k in (0, 2)] == [81.7, 137.0]
    for e in evs:
        assert set(("t", "predicted_t", "x_before", "x_after")) <= set(e) and len(e["x_after"]) == 4
    assert max(abs(v) for v in out["final_error"]) < 1e-9
    assert main(["observe", "switching_server", "--json", "--observer", "positive+projection"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["observer"] == "positive+projection" and out["nonnegative"]
    from hybobs_opt.observers.scenarios import get_scenario

    with pytest.raises(ModelError):
        get_scenario("switching_server")(argparse.Namespace(observer="paper", plot=None, json=True))
