"""The covariance of a flagged Kalman-arrival window against an independent mixture oracle.

The oracle enumerates every mode sequence of the window, solves each sequence's least-squares
problem (the whitened outputs and the arrival prior over the window-start state, subject to the
sequence's guards and the state box) with cvxpy and Clarabel, built from the system matrices
alone, and forms the evidence-weighted mixture of the sequences' Gaussian posteriors about the
reported estimate.  It shares no code with :mod:`hybobs_opt.mhe` (no MLD encoding, no condensing,
no DAQP).
"""

from __future__ import annotations

import itertools

import cvxpy as cp
import numpy as np
import pytest
from scipy.stats import chi2

from canonical import noise_study_case

from hybobs_opt import MHEObserver
from hybobs_opt.contract import FALLBACK, OBSERVABLE


def oracle_sequences(system, U, Y, xbar, Z, sigma):
    """Every mode sequence's least cost, minimiser's last state, posterior covariance and log-det."""
    n, T = system.n, U.shape[0]
    Winv = np.diag(1.0 / sigma)
    Lz = np.linalg.cholesky(Z).T  # Z = Lz' Lz
    XA, Xb = system.state_bounds.A, system.state_bounds.b
    out = {}
    for seq in itertools.product(range(system.n_modes), repeat=T):
        x0 = cp.Variable(n)
        x = x0
        cost = cp.sum_squares(Lz @ (x0 - xbar))
        cons = []
        Phi = np.eye(n)
        J = [Lz]
        for k, q in enumerate(seq):
            md = system.modes[q]
            G, g = md.guard.A, md.guard.b
            cons += [G[:, :n] @ x + G[:, n:] @ U[k] <= g, XA @ x <= Xb]
            cost = cost + cp.sum_squares(Winv @ (Y[k] - md.C @ x - md.D @ U[k] - md.c))
            J.append(Winv @ md.C @ Phi)
            if k < T - 1:
                x = md.A @ x + md.B @ U[k] + md.a
                Phi = md.A @ Phi
        prob = cp.Problem(cp.Minimize(cost), cons)
        prob.solve(solver=cp.CLARABEL)
        if prob.status in ("infeasible", "infeasible_inaccurate"):
            continue
        assert prob.status == "optimal", (seq, prob.status)
        # the last state of the minimiser, and the information of the window-start state
        xs = x0.value
        for k, q in enumerate(seq[:-1]):
            md = system.modes[q]
            xs = md.A @ xs + md.B @ U[k] + md.a
        H = sum(j.T @ j for j in J)
        out[seq] = (float(prob.value), xs, Phi @ np.linalg.inv(H) @ Phi.T, float(np.linalg.slogdet(H)[1]))
    return out


def _run(name: str, steps: int, windows: int):
    system, U, trace, sigma = noise_study_case(name, steps)
    Y = trace.y + np.random.default_rng(1).normal(size=trace.y.shape) * sigma
    obs = MHEObserver(system, 3, noise_std=sigma, arrival_weight="kalman")
    checked = multi = 0
    for k in range(steps):
        est = obs.step(U[k], Y[k])
        mix = est.info.get("mixture")
        if est.flag != OBSERVABLE or mix is None:
            continue
        if mix["n_sequences"] < 2 and checked - multi >= 2:
            continue  # a few single-sequence windows, then only those that several sequences fit
        Uw, Yw = U[k - 2: k + 1], Y[k - 2: k + 1]
        xbar = np.array(est.info["arrival"]["prior"])
        Z = np.array(est.info["arrival"]["information"])
        seqs = oracle_sequences(system, Uw, Yw, xbar, Z, np.asarray(sigma, dtype=float).reshape(-1))
        jstar = min(v[0] for v in seqs.values())
        eps = chi2.isf(obs.false_alarm, system.n)
        thr = jstar + eps
        assert mix["threshold"] == pytest.approx(thr, rel=1e-6, abs=1e-6)
        band = 1e-6 * (1.0 + thr)
        got = {tuple(s) for s in mix["sequences"]}
        inside = {s for s, v in seqs.items() if v[0] <= thr - band}
        near = {s for s, v in seqs.items() if abs(v[0] - thr) <= band}
        assert inside <= got, (k, inside - got)
        assert got <= inside | near, (k, got - inside - near)
        if near:
            continue
        # the evidence-weighted mixture about the reported estimate
        logw = np.array([-0.5 * seqs[s][0] - 0.5 * seqs[s][3] for s in sorted(got)])
        w = np.exp(logw - logw.max())
        w /= w.sum()
        P = sum(wi * (seqs[s][2] + np.outer(seqs[s][1] - est.x, seqs[s][1] - est.x)) for wi, s in zip(w, sorted(got)))
        np.testing.assert_allclose(np.array(est.info["covariance"]), P, rtol=1e-4,
                                   atol=1e-7 * np.abs(np.diag(P)).max())
        checked += 1
        multi += mix["n_sequences"] >= 2
        if multi >= windows:
            break
    return checked, multi


@pytest.mark.parametrize("name", ["model16", "dc_motor"])
def test_flagged_covariance_is_the_mixture_of_every_fitting_sequence(name):
    checked, multi = _run(name, 400, 3)
    assert multi >= 3, f"only {multi} flagged windows that several mode sequences fit ({checked} checked)"


def test_a_window_more_sequences_fit_than_allowed_is_not_flagged(monkeypatch):
    import hybobs_opt.mhe.observer as observer_module

    monkeypatch.setattr(observer_module, "MHE_MIXTURE_MAX_SEQUENCES", 1)
    system, U, trace, sigma = noise_study_case("dc_motor", 200)
    Y = trace.y + np.random.default_rng(1).normal(size=trace.y.shape) * sigma
    obs = MHEObserver(system, 3, noise_std=sigma, arrival_weight="kalman")
    steps = [obs.step(U[k], Y[k]) for k in range(200)]
    stopped = [e for e in steps if "mixture" in e.info and not e.info["mixture"]["complete"]]
    assert stopped, "no window that two mode sequences fit"
    for e in stopped:
        assert e.flag == FALLBACK
        assert "more than 1 mode sequences fit" in e.info["reason"]
    assert all(e.info["mixture"]["n_sequences"] == 1 for e in steps if e.flag == OBSERVABLE)
