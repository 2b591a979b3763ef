"""Paper 003's examples: the two-product switching server and the signalized 3-flow T-junction.

"Observer design for piecewise affine hybrid systems with constant drift": the switching server
is the running example of Section 2.1, the T-junction the application of Section 5.  Both are
:class:`~hybobs_opt.systems.constant_drift.ConstantDriftSystem` s (eq. 3) with states
``x0`` (remaining setup / clearing time) and ``x1 ... xN`` (buffer contents / queue lengths),
named as in the paper.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.sim.constant_drift import simulate_constant_drift
from hybobs_opt.sim.trace import Trace
from hybobs_opt._validate import as_vector
from hybobs_opt.systems.constant_drift import ConstantDriftSystem

# ---------------------------------------------------------------------------- switching server

#: Initial buffer contents ``[x1(0), x2(0)]`` of the switching-server scenario.  The paper gives
#: none (Section 2.1 is symbolic); these are chosen, with ``x0(0) = alpha_Q``, ``q(0) = 1``,
#: ``t0 = 0`` from the paper's initial-condition convention (Section 2.1, after eq. 3).
SERVER_X0_BAR: tuple[float, float] = (10.0, 5.0)

#: Horizon of the switching-server scenario (s): a few cycles of the default parameters.
SERVER_T_FINAL: float = 60.0


def switching_server(
    lam1: float = 1.0,
    mu1: float = 3.0,
    mu2: float = 4.0,
    gamma1: float = 2.0,
    gamma2: float = 1.0,
) -> ConstantDriftSystem:
    """The two-product switching server of paper 003, Section 2.1 (Figure 1).

    Implements the drift vectors ``f_1 = f_3 = [-1, lam1, 0]``, ``f_2 = [0, lam1 - mu1, mu1]``,
    ``f_4 = [0, lam1, -mu2]``, the triggering components ``k_1 = k_3 = 1, k_2 = 2, k_4 = 3``
    (eq. 3), the resets ``alpha_1 = alpha_3 = 0, alpha_2 = gamma2, alpha_4 = gamma1`` (eq. 2) and
    the outputs ``h_1 = h_2 = h_3 = 0, h_4 = 4`` (only "serving job type 2" is seen) of Section 2.1.
    Modes: 1 setup type 1, 2 serve type 1, 3 setup type 2, 4 serve type 2.  Served type-1 jobs
    move to buffer 2.

    Parameters
    ----------
    lam1 : float, default 1.0
        Arrival rate at buffer 1 (jobs/s), ``lam1 > 0`` (Section 2.1).
    mu1, mu2 : float, default 3.0 and 4.0
        Processing rates of job types 1 and 2 (jobs/s); ``mu1 > lam1`` is needed by
        Assumption 2.1 (buffer 1 must drain while served).
    gamma1, gamma2 : float, default 2.0 and 1.0
        Setup times to switch to job type 1 and 2 (s).

    Notes
    -----
    The paper keeps every parameter symbolic; the defaults are chosen here (not from the paper),
    with load ``lam1/mu1 + lam1/mu2 = 7/12 < 1`` so the buffers stay bounded.  The paper allows
    ``gamma_n >= 0`` with ``gamma1 + gamma2 > 0``, but with this four-mode model a zero setup
    violates Assumption 2.3 (``alpha_q > 0 <=> k_sigma(q) = 1``: the setup mode after it would
    last 0 s, yet it is a timer mode), so both setup times must be positive here; a zero setup
    would need the setup mode removed from the cycle.

    Raises
    ------
    ModelError
        For ``lam1 <= 0``, non-finite values, or any violated Assumption 2.1-2.6 (field names the
        assumption and mode).
    """
    values = {k: _scalar(v, k) for k, v in dict(lam1=lam1, mu1=mu1, mu2=mu2, gamma1=gamma1, gamma2=gamma2).items()}
    lam1, mu1, mu2, g1, g2 = (values[k] for k in ("lam1", "mu1", "mu2", "gamma1", "gamma2"))
    if not lam1 > 0:
        raise ModelError("lam1", "an arrival rate lam1 > 0 (Section 2.1)", f"{lam1}")
    f = np.array(
        [
            [-1.0, lam1, 0.0],
            [0.0, lam1 - mu1, mu1],
            [-1.0, lam1, 0.0],
            [0.0, lam1, -mu2],
        ]
    )
    return ConstantDriftSystem(
        f=f,
        trigger=np.array([0, 1, 0, 2]),
        alpha=np.array([0.0, g2, 0.0, g1]),
        h=np.array([0, 0, 0, 4]),
        state_names=("x0", "x1", "x2"),
        mode_names=("setup type 1", "serve type 1", "setup type 2", "serve type 2"),
    )


def switching_server_scenario(system: ConstantDriftSystem, t_final: float | None = None) -> Trace:
    """Simulate the switching server from the paper's initial-condition convention.

    ``t0 = 0``, ``q(0) = 1``, ``x0(0) = alpha_Q`` (paper 003, Section 2.1, after eq. 3) and the
    chosen buffer contents :data:`SERVER_X0_BAR`; sampled every 0.1 s besides the events.
    """
    t_end = SERVER_T_FINAL if t_final is None else t_final
    x0 = np.concatenate([[system.alpha[-1]], SERVER_X0_BAR])
    return simulate_constant_drift(system, x0, 1, 0.0, t_end, dt=0.1)


# ---------------------------------------------------------------------------- T-junction

#: True initial queue lengths ``[x1(0), x2(0), x3(0)]`` of the junction scenario, at ``t0 = 0``
#: with ``q(0) = 1`` and ``x0(0) = alpha_Q = gamma1`` (the paper's convention, Section 2.1).
#: Paper 003 does not print the true state; these round numbers make the true system's visible
#: events after the observer start ``t = 50`` fall at 70.714, 79.184 and 140.306 s, i.e. at the
#: 70.7, 79.2 and 140.3 s printed in Section 5 (found by a search over integer queue lengths;
#: other initial states give the same rounded times, the state at 50 s is not unique).
JUNCTION_X0_BAR: tuple[float, float, float] = (40.0, 60.0, 0.0)

#: Time at which the paper starts the observer (Section 5).
JUNCTION_OBSERVER_START: float = 50.0

#: The observer's initial estimate of the queues ``[x1, x2, x3]`` at 50 s and its mode (Section 5;
#: mode 4 = serving flow 2).  Not used by the simulation: kept for the observer examples.
JUNCTION_ESTIMATE_X_BAR: tuple[float, float, float] = (70.0, 20.0, 30.0)
JUNCTION_ESTIMATE_MODE: int = 4

#: Visible event times of the true system printed in Section 5 (s, to 0.1 s).
JUNCTION_PAPER_VISIBLE_EVENTS: tuple[float, float, float] = (70.7, 79.2, 140.3)

#: Horizon of the junction scenario (s): past the paper's last quoted event at 140.3 s.
JUNCTION_T_FINAL: float = 200.0


def traffic_junction(
    lam: Sequence[float] = (1.0, 2.0, 3.0),
    mu: Sequence[float] = (8.0, 10.0, 12.0),
    gamma: Sequence[float] = (5.0, 10.0, 15.0),
) -> ConstantDriftSystem:
    """The signalized T-junction with three vehicle flows of paper 003, Section 5 (Figure 2).

    Implements Section 5's data of system (3): modes ``2i-1`` set up (clear the junction for)
    flow ``i`` and modes ``2i`` serve flow ``i``, in the fixed order 1, 2, 3;
    ``f_1 = f_3 = f_5 = [-1, lam1, lam2, lam3]``, ``f_2 = [0, lam1 - mu1, lam2, lam3]``,
    ``f_4 = [0, lam1, lam2 - mu2, lam3]``, ``f_6 = [0, lam1, lam2, lam3 - mu3]``;
    ``alpha_1 = alpha_3 = alpha_5 = 0, alpha_2 = gamma2, alpha_4 = gamma3, alpha_6 = gamma1``;
    ``k_1 = k_3 = k_5 = 1, k_2 = 2, k_4 = 3, k_6 = 4``; ``h_2 = 2`` and all other ``h_q = 0`` (a
    sensor sees vehicles crossing from lane 1, i.e. only "serving flow 1" is visible).

    Parameters
    ----------
    lam : sequence of float, default (1, 2, 3)
        Arrival rates ``lambda_i`` (vehicles/s), Section 5.
    mu : sequence of float, default (8, 10, 12)
        Service (discharge) rates ``mu_i`` (vehicles/s), Section 5; ``mu_i > lambda_i`` is needed
        by Assumption 2.1.
    gamma : sequence of float, default (5, 10, 15)
        Clearing/setup times ``gamma_i`` (s) before serving flow ``i``, Section 5; each must be
        positive (Assumption 2.3).

    Notes
    -----
    Any number ``n >= 1`` of flows is accepted (the same pattern with ``2n`` modes, the sensor
    still on flow 1); the paper's junction has ``n = 3``.  Units follow the paper, which gives
    none: seconds and vehicles are assumed.

    Raises
    ------
    ModelError
        For mismatched lengths, non-finite or negative rates, or a violated Assumption 2.1-2.6.
    """
    lam_v = as_vector(lam, "lam", None)
    n = lam_v.size
    mu_v = as_vector(mu, "mu", n)
    gamma_v = as_vector(gamma, "gamma", n)
    bad = np.nonzero(lam_v < 0)[0]
    if bad.size:
        raise ModelError(f"lam[{int(bad[0])}]", "an arrival rate >= 0 (Section 5)", f"{lam_v[bad[0]]}")
    Q = 2 * n
    f = np.zeros((Q, n + 1))
    f[:, 1:] = lam_v
    trigger = np.zeros(Q, dtype=int)
    alpha = np.zeros(Q)
    for i in range(n):
        setup, serve = 2 * i, 2 * i + 1  # 0-based rows of modes 2i+1 and 2i+2
        f[setup, 0] = -1.0
        f[serve, 1 + i] -= mu_v[i]
        trigger[serve] = 1 + i
        alpha[serve] = gamma_v[(i + 1) % n]  # leaving "serve flow i" starts the setup of flow i+1
    h = np.zeros(Q, dtype=int)
    h[1] = 2
    return ConstantDriftSystem(
        f=f,
        trigger=trigger,
        alpha=alpha,
        h=h,
        state_names=tuple(f"x{i}" for i in range(n + 1)),
        mode_names=tuple(name for i in range(1, n + 1) for name in (f"setup flow {i}", f"serve flow {i}")),
    )


def traffic_junction_scenario(system: ConstantDriftSystem, t_final: float | None = None) -> Trace:
    """The true T-junction trajectory of paper 003, Section 5 (dashed lines of Figure 3).

    Starts at ``t0 = 0`` in mode 1 with ``x0(0) = alpha_Q`` (= ``gamma1``) and queues
    :data:`JUNCTION_X0_BAR` = ``[40, 60, 0]``; with the paper's parameters its visible events
    after the observer start (50 s) are at 70.7 s (serving flow 1 starts), 79.2 s (queue 1 empty)
    and 140.3 s (serving flow 1 again), as printed in Section 5.  Sampled every 0.1 s besides the
    events.
    """
    t_end = JUNCTION_T_FINAL if t_final is None else t_final
    x0 = np.concatenate([[system.alpha[-1]], JUNCTION_X0_BAR])
    return simulate_constant_drift(system, x0, 1, 0.0, t_end, dt=0.1)


def _scalar(value, name: str) -> float:
    if isinstance(value, bool):
        raise ModelError(name, "a finite real number", f"{value!r}")
    return float(as_vector(value, name, 1)[0])
