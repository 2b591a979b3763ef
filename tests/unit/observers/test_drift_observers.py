"""Event-sampled models and observers of constant-drift hybrid systems (paper 003, Sections 3-5).

Expected values come from hand computations written out below, from the paper's gains (20a-b)
or from the exact event-time simulator (tested in test_constant_drift.py).  Nothing is compared
with a number produced by the code under test.  The paper's printed matrices (Sections 3 and 5),
the gains (20a-b) and the numbers of the Section 5 run are checked in
``tests/studies/test_paper003_switching.py``; ``hybobs observe`` in ``tests/app/test_cli_drift.py``
and the report's section in ``tests/app/test_report_drift.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.contract import FALLBACK, OBSERVABLE
from hybobs_opt.errors import InfeasibleError, ModelError
from hybobs_opt.observers.drift_observer import DriftObserver
from hybobs_opt.observers.periodic import PeriodicObserver
from hybobs_opt.synthesis.periodic_gains import (
    CopositiveCertificate,
    NoDeadbeatCertificate,
    PerronCertificate,
    deadbeat_gains,
    positive_deadbeat_gains,
    positive_gain_bounds,
    positive_observer,
)
from hybobs_opt.sim import simulate_constant_drift
from hybobs_opt.studies.paper003_switching.comparison import polling_server, unserved_buffer_server, visible_samples
from hybobs_opt.studies.paper003_switching.scenarios import run_drift_scenario
from hybobs_opt.studies.paper003_switching.systems import switching_server, traffic_junction
from hybobs_opt.systems import ConstantDriftSystem
from hybobs_opt.systems.event_sampled import PeriodicSystem, periodic_system

LAM = (1.0, 2.0, 3.0)
MU = (8.0, 10.0, 12.0)
GAMMA = (5.0, 10.0, 15.0)

# switching-server parameters for the symbolic matrices of Section 3 (chosen: the paper keeps them symbolic)
L1_, M1_, M2_, G1_, G2_ = 1.5, 4.0, 5.0, 2.0, 3.0


@pytest.fixture(scope="module")
def junction():
    return traffic_junction(lam=LAM, mu=MU, gamma=GAMMA)


@pytest.fixture(scope="module")
def server():
    return switching_server(lam1=L1_, mu1=M1_, mu2=M2_, gamma1=G1_, gamma2=G2_)


def paper_gains_20():
    """(20a-b) written out for lam = [1 2 3], mu3 = 12: L1 = [0 lam2 lam3], L2 = [lam1 lam2 lam3/mu3 0]."""
    l1, l2, l3 = LAM
    return np.array([[0.0, l2, l3], [l1, l2 * l3 / MU[2], 0.0]])


# ---------------------------------------------------------------------------- event-sampled models
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
        obs.reset([0.0, 300.0, 0.0], t0=0.0, q0=4)
        out = obs.run_trace(tr)
        mins[label] = out.x_hat[:, 1:].min()
        assert np.max(np.abs(out.x_hat[-1] - tr.x[-1])) < 1e-6 * (1 + np.abs(tr.x[-1]).max())
    assert mins["deadbeat"] < -1.0 and mins["positive"] >= 0.0
    # Remark 4.4: the projected deadbeat estimate is non-negative and still converges
    obs = DriftObserver(system, deadbeat_gains(ps), project=True)
    obs.reset([0.0, 300.0, 0.0], t0=0.0, q0=4)
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


# ---------------------------------------------------------------------------- observer runs
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
    obs.reset(xh, t0=t[1], q0=int(v[1]))
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
    for kwargs, field in ((dict(x0=[0.0, -1.0, 2.0, 3.0], q0=4), "x0[x1]"), (dict(x0=[3.0, 1.0, 2.0, 3.0], q0=4), "x0[x0]"),
                          (dict(x0=[0.0, 1.0, 2.0], q0=4), "x0"), (dict(q0=9), "q0"), (dict(t0=np.nan), "t0")):
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
    obs.reset([0.0, 70.0, 20.0, 30.0], t0=50.0, q0=4)
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
    po.reset([1.0, 2.0, 3.0], t0=10.0, q0=1)
    assert po.step([20.0], [6]).flag == FALLBACK and po.step([5.0], [2]).flag == FALLBACK


def test_initial_mode_mismatch_then_resync(junction):
    # started in the wrong mode (3, clearing for flow 2) while the junction serves flow 1 (y = 2):
    # the first sample is flagged, the end of serving flow 1 (79.2) is not the visible event the
    # observer expects (entering serve 1), so it resynchronises; later events are regular (18d-e)
    # and the deadbeat gains make the estimate exact.
    from hybobs_opt.studies.paper003_switching.systems import traffic_junction_scenario

    tr = traffic_junction_scenario(junction, t_final=300.0)
    obs = DriftObserver(junction, paper_gains_20())
    obs.reset([GAMMA[1], 0.0, 50.0, 50.0], t0=75.0, q0=3)
    keep = tr.t >= 75.0
    out = obs.run(tr.t[keep], tr.y[keep, 0])
    assert out.flags[0] == FALLBACK
    kinds = [r.kind for r in obs.events]
    assert kinds[0] == "resync" and kinds[1:5] == ["18d", "18e"] * 2 and len(kinds) >= 5
    assert abs(obs.events[0].t - 79.2) < 0.05 and obs.events[0].x_after[0] == GAMMA[1]
    # four regular updates after the resync: exact (deadbeat index 4), flagged observable from the fifth
    np.testing.assert_allclose(out.x_hat[-1], tr.x[-1], atol=1e-9)
