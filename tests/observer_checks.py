"""Independent checks of observer runs shared by the unit tests and the study tests.

Each one recomputes its answer from the run's raw arrays or the model's matrices (numpy only),
never from a number the observer reports:

* :func:`assert_step_by_step`, :func:`assert_indicator_window` -- the step-by-step convergence of
  the sliding-mode observer of paper 001 and its mode indicator (the paper's Examples 1-3 in
  ``studies/test_paper001_sliding_mode.py``, the relay oscillator in ``unit/observers/test_sliding_mode.py``);
* :func:`frozen_jacobian_lyapunov` -- the Lyapunov inequality of a switched gain at a frozen
  Jacobian (paper 004; ``unit/lmi/test_lmi.py`` and ``studies/test_paper004_nonmonotonic.py``);
* :func:`delays_from_events` -- detection delays of a location observer from the simulator's event
  log (paper 000; ``unit/observers/test_location_observer.py`` and ``studies/test_paper000_driveline.py``).
"""

from __future__ import annotations

import numpy as np

# ------------------------------------------------------------------ sliding-mode observer (paper 001)
#: Indicator window stated for noise-free runs: S_o may differ from S only within this many
#: samples of a true switch (the auxiliary states lag by about one sample per stage).
WINDOW_SAMPLES = 10


def convergence_times(t, err, band):
    """First time after which |err| <= band for good (computed here, independently of the module)."""
    out = []
    for j in range(err.shape[1]):
        bad = np.nonzero(np.abs(err[:, j]) > band[j])[0]
        out.append(t[0] if bad.size == 0 else (t[bad[-1] + 1] if bad[-1] + 1 < t.size else np.inf))
    return np.array(out)


def assert_step_by_step(res, band, t_limit):
    err = res.run.z_hat - res.z_true
    tc = convergence_times(res.t, err, band)
    assert np.all(np.isfinite(tc)), f"not converged to the band: {tc}"
    assert np.all(np.diff(tc) > 0), f"not step by step (z1, then z2, ...): {tc}"
    assert tc[-1] < t_limit
    # the anti-peaking switches close in order too
    first_closed = [res.t[np.argmax(res.run.sliding[:, j])] for j in range(res.form.n)]
    assert np.all(np.diff(first_closed) > 0)
    return tc


def assert_indicator_window(res):
    """S_o == S except within WINDOW_SAMPLES samples of a switch of S (after all stages slide)."""
    h = res.observer.Ts
    after = res.t >= res.t_settled
    t, S, So = res.t[after], res.S[after], res.run.mode[after]
    switches = t[1:][np.diff(S) != 0]
    assert switches.size >= 1
    bad = t[So != S]
    for tb in bad:
        assert np.min(np.abs(switches - tb)) <= WINDOW_SAMPLES * h + 1e-12
    assert np.mean(So != S) <= 2 * WINDOW_SAMPLES * switches.size / t.size + 1e-12


# ------------------------------------------------------------------ switched gains (paper 004)
def frozen_jacobian_lyapunov(system, L, P, sigma, x):
    """max eig of J'P + PJ + sigma P with J = A + F diag(f'(Ex)) E - L diag(h'(Cx)) C (eqs. 7, 10)."""
    fd = np.array([fn.deriv(np.array([z]))[0] for fn, z in zip(system.f, system.E @ x)]) if system.r else np.zeros(0)
    hd = np.array([fn.deriv(np.array([z]))[0] for fn, z in zip(system.h, system.C @ x)])
    J = system.A + system.F @ np.diag(fd) @ system.E - L @ np.diag(hd) @ system.C
    return float(np.linalg.eigvalsh(J.T @ P + P @ J + sigma * P).max()), J


# ------------------------------------------------------------------ location observer (paper 000)
def delays_from_events(t: np.ndarray, events: list[dict], location: np.ndarray) -> list[float]:
    """From each true change to the first sample whose estimate is the new location (inf if none)."""
    out = []
    for k, e in enumerate(events):
        t_end = events[k + 1]["t"] if k + 1 < len(events) else np.inf
        hit = np.nonzero((t >= e["t"]) & (t < t_end) & (location == e["to"]))[0]
        out.append(float(t[hit[0]] - e["t"]) if hit.size else np.inf)
    return out
