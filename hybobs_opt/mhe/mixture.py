"""The Gaussian posterior of a window that several mode sequences fit: a mixture over the sequences.

With Gaussian output noise of the stated level (``MHEObserver(noise_std=...)``) and the Kalman
arrival cost, the cost of eq. (10) of paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000) is
twice the negative log-posterior of the window, ``J = -2 log p(x, Y | q) + const``, for each mode
sequence ``q``.  With ``q`` fixed the window is linear-Gaussian, so its posterior is the Gaussian
of the sequence's least-squares problem: mean ``m_q`` (the minimiser's last-sample state) and
covariance ``P_q = Px (R_q' R_q)^-1 Px'``.  When several sequences fit the data, the posterior of
the state is the mixture of these Gaussians weighted by each sequence's evidence

    w_q  proportional to  exp(-J_q / 2) det(R_q' R_q)^(-1/2)

(a uniform prior over the sequences; Bishop, *Pattern Recognition and Machine Learning*, 2006,
sec. 3.4 and 9.2; for hybrid estimation, the multiple-model posterior of Bar-Shalom, Li &
Kirubarajan, *Estimation with Applications to Tracking and Navigation*, 2001, sec. 11.6).  The
covariance stated about the reported estimate ``x^`` (the optimum's last state) is the mixture's
second moment about it,

    P = sum_q w_q (P_q + (m_q - x^)(m_q - x^)'),

which includes the spread of the sequences' means.  Sequences whose least cost exceeds the
chi-square threshold ``J* + chi2_n^-1(1 - false_alarm)`` are left out: their evidence is at most
``exp(-epsilon / 2)`` of the optimum's (2.6e-3 of it for ``n = 2`` and a false alarm of 1e-3).

Which sequences fit is decided exactly: a depth-first search over mode prefixes, each prefix's
least cost a lower bound of every sequence beginning with it, proven in numpy by weak duality
(:meth:`~hybobs_opt.mhe.window.WindowModel.sequence_qp`).  A prefix is closed only when its proven
bound exceeds the threshold; a sequence is kept when its proven bound does not (so a sequence at
the threshold is kept, the safe side: it only widens ``P``).  The search that stops at its budget
returns ``complete=False`` and the observer does not flag the step.

What is not modelled: the truncation of each Gaussian by its sequence's guard rows (the mean is the
constrained minimiser, the covariance the unconstrained one's).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .certify import leaf_trajectory

__all__ = ["SequenceMixture", "sequence_mixture", "sequence_posterior_covariance"]


@dataclass(frozen=True)
class SequenceMixture:
    """The mode sequences that fit a window within the chi-square threshold, and their mixture.

    Parameters
    ----------
    modes : (k, T) int array
        The fitting mode sequences, least cost first.
    costs : (k,) array
        Each sequence's cost of eq. (10) at its minimiser (original units).
    weights : (k,) array
        Their normalised evidences (sum 1).
    means : (k, n) array
        Each sequence's last-sample state at its minimiser.
    covariances : (k, n, n) array
        Each sequence's Gaussian posterior covariance of the last-sample state.
    covariance : (n, n) array
        The mixture's second moment about the reported estimate (``nan`` when not ``complete``).
    threshold : float
        ``J* + epsilon``, the cost a fitting sequence does not exceed.
    complete : bool
        Every mode prefix was closed: no other sequence fits.
    nodes : int
        Prefix QPs solved.
    seconds : float
        Wall time.
    reason : str
        Why the search is not complete (empty when it is).

    See Also
    --------
    sequence_mixture : Returns one.
    MHEObserver : States its covariance with ``arrival_weight="kalman"``.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import sequence_mixture
    >>> obs = MHEObserver(plant, 3, noise_std=0.01, arrival_weight="kalman")
    >>> res = obs.solve_window(U[:3], truth.y[:3])
    >>> mix = sequence_mixture(obs.model, U[:3], truth.y[:3], obs.model.cx, res.states[-1],
    ...                        float(res.cost) + 10.0, max_sequences=8, max_nodes=1000)
    >>> mix.complete, mix.modes.shape[1], round(float(mix.weights.sum()), 6)
    (True, 3, 1.0)
    >>> mix.covariance.shape
    (3, 3)
    """

    modes: np.ndarray
    costs: np.ndarray
    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    covariance: np.ndarray
    threshold: float
    complete: bool
    nodes: int
    seconds: float
    reason: str = ""

    def to_dict(self) -> dict:
        """JSON-ready summary (``Estimate.info["mixture"]``).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        out = {"complete": self.complete, "n_sequences": int(len(self.costs)), "threshold": float(self.threshold),
               "sequences": [[int(q) for q in s] for s in self.modes], "costs": self.costs.tolist(),
               "weights": self.weights.tolist(), "nodes": int(self.nodes), "seconds": float(self.seconds)}
        if self.reason:
            out["reason"] = self.reason
        return out


def sequence_posterior_covariance(model, modes, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray) -> np.ndarray:
    """Gaussian posterior covariance of the last window state when the mode sequence is ``modes``.

    The inverse of the whitened cost's information ``R' R`` in the window-start state (and
    disturbances), mapped to the last sample through the sequence's dynamics.
    """
    return _posterior_covariance(model, modes, model.sequence_problem(modes, U, Y, xbar)[0])


def _posterior_covariance(model, modes, R: np.ndarray) -> np.ndarray:
    """:func:`sequence_posterior_covariance` from the sequence's whitened residual matrix ``R``."""
    n, T = model.n, model.T
    nt = R.shape[1]
    Px = np.zeros((n, nt))
    Px[:, :n] = np.diag(model.hx)
    for k in range(T - 1):
        Px = model.system.modes[int(modes[k])].A @ Px
        if nt > n:
            Px[:, n + k * n: n + (k + 1) * n] += np.diag(model.hx)
    cov = Px @ np.linalg.pinv(R.T @ R) @ Px.T
    return 0.5 * (cov + cov.T)


def sequence_mixture(model, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, x_hat: np.ndarray, threshold: float, *,
                     max_sequences: int, max_nodes: int, deadline: float | None = None) -> SequenceMixture:
    """Every mode sequence whose least window cost is at most ``threshold``, and their mixture.

    Parameters
    ----------
    model : WindowModel
        The window's model (norm 2, output weights ``1 / noise_std``).
    U, Y : arrays
        The window's inputs ``(T, m)`` and outputs ``(T, p)``.
    xbar : (n,) array
        The arrival prior.
    x_hat : (n,) array
        The reported estimate (the optimum's last state), about which the covariance is stated.
    threshold : float
        ``J* + epsilon``.
    max_sequences : int
        More fitting sequences than this stop the search (``complete=False``).
    max_nodes : int
        Prefix QPs allowed.
    deadline : float, optional
        ``time.perf_counter()`` value after which the search stops.

    Returns
    -------
    SequenceMixture

    See Also
    --------
    SequenceMixture : What it returns.
    search_sequences : The optimum of the same window.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import sequence_mixture
    >>> obs = MHEObserver(plant, 3, noise_std=0.01, arrival_weight="kalman")
    >>> res = obs.solve_window(U[:3], truth.y[:3])
    >>> mix = sequence_mixture(obs.model, U[:3], truth.y[:3], obs.model.cx, res.states[-1],
    ...                        float(res.cost) + 10.0, max_sequences=8, max_nodes=1000)
    >>> mix.complete, len(mix.costs) >= 1
    (True, True)
    """
    t0 = time.perf_counter()
    T = model.T
    n_modes = model.system.n_modes
    found: list[tuple[float, tuple[int, ...], np.ndarray, float, np.ndarray]] = []  # cost, modes, last state, logdet, R
    nodes = 0

    def stop(reason: str) -> SequenceMixture:
        return _mixture(model, found, x_hat, threshold, False, nodes, t0, reason)

    stack: list[tuple[int, ...]] = [()]
    while stack:
        prefix = stack.pop()
        for q in range(n_modes):
            seq = prefix + (q,)
            nodes += 1
            if nodes > max_nodes:
                return stop(f"node budget of {max_nodes} QPs exhausted")
            if deadline is not None and time.perf_counter() > deadline:
                return stop(f"time budget exhausted after {nodes - 1} prefix QPs")
            problem = model.sequence_problem(seq, U, Y, xbar)
            solved = model.sequence_qp(problem, None, bound=True)
            if solved is None:
                return stop(f"the QP of the mode prefix {seq} has no certified answer")
            theta, lower = solved
            if theta is None or lower > threshold:
                continue  # proven: no sequence beginning with it fits
            if len(seq) < T:
                stack.append(seq)
                continue
            _, _, states, cost = leaf_trajectory(model, seq, theta, problem, U, Y, xbar)
            R = problem[0]
            sign, logdet = np.linalg.slogdet(R.T @ R)
            if sign <= 0 or not np.isfinite(logdet):
                return stop(f"the mode sequence {seq} fits but leaves a direction of the window unobserved "
                            "(singular information): its posterior has no covariance")
            found.append((cost, seq, states[-1].copy(), float(logdet), R))
            if len(found) > max_sequences:
                return stop(f"more than {max_sequences} mode sequences fit within the chi-square threshold")
    if not found:
        return stop("no mode sequence fits within the threshold (the optimum's own sequence was not found)")
    return _mixture(model, found, x_hat, threshold, True, nodes, t0, "")


def _mixture(model, found, x_hat, threshold, complete, nodes, t0, reason) -> SequenceMixture:
    """The :class:`SequenceMixture` of the sequences found (least cost first); its covariance only when ``complete``."""
    n = model.n
    found = sorted(found, key=lambda item: item[0])
    k = len(found)
    modes = np.array([item[1] for item in found], dtype=int).reshape(k, model.T)
    costs = np.array([item[0] for item in found], dtype=float)
    means = np.array([item[2] for item in found], dtype=float).reshape(k, n)
    logw = np.array([-0.5 * item[0] - 0.5 * item[3] for item in found], dtype=float)
    weights = np.exp(logw - logw.max()) if k else logw
    weights = weights / weights.sum() if k else weights
    covs = np.array([_posterior_covariance(model, item[1], item[4]) for item in found]).reshape(k, n, n)
    cov = np.full((n, n), np.nan)
    if complete:
        d = means - np.asarray(x_hat, dtype=float)[None, :]
        cov = np.einsum("k,kij->ij", weights, covs) + np.einsum("k,ki,kj->ij", weights, d, d)
        cov = 0.5 * (cov + cov.T)
    return SequenceMixture(modes, costs, weights, means, covs, cov, float(threshold), complete, nodes,
                           time.perf_counter() - t0, reason)
