"""A certified bound on the error of a Luenberger-type observer, behind its ``observable`` flag.

A Luenberger-type observer (the continuous observer of paper 000, the switched-gain observer of
paper 004) reconstructs the state only asymptotically: its first estimates are as wrong as its
initial guess.  It flags ``observable`` only once a bound on its error, certified by its design's
Lyapunov function, is below :data:`~hybobs_opt.defaults.CONVERGENCE_FRACTION` of the state set's width in every
coordinate; before, it flags ``warming_up`` (DESIGN.md: a flag ``observable`` means the state is
determined by the data).

The bound is kept as one number, ``b >= ||e||_P`` with ``P`` the Lyapunov matrix in use:

* at a reset, ``b`` is the largest ``||x0 - v||_P`` over the vertices ``v`` of the state box (the
  plant is somewhere in the box; a convex function of ``v`` is largest at a vertex);
* a step multiplies it by the step's contraction in the ``P``-norm (the induced norm of a sampled
  error map, or ``exp(-sigma dt / 2)`` from ``V' <= -sigma V``); an open-loop step by the open
  loop's factor;
* a change of Lyapunov matrix ``P -> P'`` multiplies it by ``sqrt(lambda_max(P^-1 P'))``;

and ``|e_k| <= b sqrt((P^-1)_kk)`` per coordinate.  The bound holds under the design's own
hypotheses (the gains' region or location is the plant's, noise-free outputs, and for the sampled
observers of paper 000 a plant that is the sampled model: inputs held and outputs linear between
samples); it is what the design proves, no more.  What it leaves out is measured, not proven: on
the driveline the continuous observer's output residual settles near 2e-4 rad/s while the bound
goes to 1e-13 (the plant between samples is not the sampled model), which is why the innovation
tests allow :data:`~hybobs_opt.defaults.INNOVATION_MARGIN` on top of it and the suite's oracle
1e-3 of the box.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.linalg import eigh

from ..defaults import CONVERGENCE_FRACTION, ERROR_BOUND_MAX_VERTEX_STATES


#: ``log`` of the largest float: a bound beyond it is reported as that (``exp`` would overflow).
LOG_FLOAT_MAX: float = math.log(np.finfo(float).max)
#: Smallest positive float: keeps ``log`` of a zero gain finite (an exact zero contracts to -inf anyway).
FLOAT_TINY: float = float(np.finfo(float).tiny)


class ErrorBound:
    """``b >= ||x_hat - x||_P``, updated step by step (see the module docstring).

    Parameters
    ----------
    lo, hi : (n,) arrays
        The state box the plant stays in.
    fraction : float
        Converged when ``b sqrt((P^-1)_kk) <= fraction (hi_k - lo_k)`` for every ``k``.
    """

    def __init__(self, lo: np.ndarray, hi: np.ndarray, fraction: float = CONVERGENCE_FRACTION):
        self.lo, self.hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self.tol = fraction * (self.hi - self.lo)
        self.log_b = math.inf

    def start(self, x0: np.ndarray, P: np.ndarray) -> None:
        """The bound at a reset to ``x0``: the farthest box vertex in the ``P``-norm."""
        n = self.lo.size
        if not (np.all(np.isfinite(self.lo)) and np.all(np.isfinite(self.hi))):
            self.log_b = math.inf
            return
        if n <= ERROR_BOUND_MAX_VERTEX_STATES:
            V = np.array(list(itertools.product(*zip(self.lo, self.hi))), dtype=float)
            D = V - np.asarray(x0, dtype=float)[None, :]
            b2 = float(np.max(np.einsum("ki,ij,kj->k", D, P, D)))
        else:
            d = np.maximum(np.abs(x0 - self.lo), np.abs(self.hi - x0))
            b2 = float(eigh(P, eigvals_only=True)[-1] * d @ d)
        self.log_b = 0.5 * math.log(b2) if b2 > 0 else -math.inf

    def contract(self, log_factor: float) -> None:
        """One step whose error map has ``P``-norm at most ``exp(log_factor)``."""
        self.log_b += log_factor

    def change_metric(self, P_old: np.ndarray, P_new: np.ndarray) -> None:
        """The Lyapunov matrix in use changes (a region switch)."""
        self.log_b += 0.5 * math.log(max(float(eigh(P_new, P_old, eigvals_only=True)[-1]), FLOAT_TINY))

    def per_state(self, P_inv_diag: np.ndarray) -> np.ndarray:
        """``|e_k|`` bounds from the diagonal of ``P^-1``."""
        return math.exp(min(self.log_b, LOG_FLOAT_MAX)) * np.sqrt(P_inv_diag)

    def output_bound(self, C_norms: np.ndarray) -> np.ndarray:
        """``|C_j e|`` bounds, given ``C_norms[j] = sqrt(C_j P^-1 C_j')`` (Cauchy-Schwarz in the ``P``-norm)."""
        return math.exp(min(self.log_b, LOG_FLOAT_MAX)) * np.asarray(C_norms, dtype=float)

    def save(self) -> float:
        """The bound's state, for :meth:`restore` (a refused step is undone)."""
        return self.log_b

    def restore(self, saved: float) -> None:
        self.log_b = saved

    def converged(self, P_inv_diag: np.ndarray) -> bool:
        return bool(np.all(self.per_state(P_inv_diag) <= self.tol))


def induced_log_norm(M: np.ndarray, P: np.ndarray) -> float:
    """``log ||P^{1/2} M P^{-1/2}||_2``: the log of ``M``'s gain in the ``P``-norm."""
    w = float(eigh(M.T @ P @ M, P, eigvals_only=True)[-1])
    return 0.5 * math.log(max(w, FLOAT_TINY))


__all__ = ["ErrorBound", "FLOAT_TINY", "LOG_FLOAT_MAX", "induced_log_norm"]
