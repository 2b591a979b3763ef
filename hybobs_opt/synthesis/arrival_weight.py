"""The arrival weight of the moving-horizon observer tuned from the noise level, certified for every
mode sequence (an LMI).

The moving-horizon observer of eq. (10) of paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000)
takes an optional arrival cost ``||W_a (x(t-T+1) - x_bar)||^2`` (Ferrari-Trecate, Mignone &
Morari, 2002, "Moving horizon estimation for hybrid systems", IEEE TAC 47(10)).  For a
linear-Gaussian model the arrival cost that makes the moving-horizon estimate equal the Kalman
filter is the inverse of the filter's one-step prediction covariance ``P`` (Rao, Rawlings & Lee,
2001, "Constrained linear state estimation -- a moving horizon approach", Automatica 37(10)):
a heavier weight claims more than the data before the window support, and an estimate pulled by
it can be wrong and look certain.  ``P`` follows the Riccati map of the mode in force,

``F_q(P) = A_q (P^-1 + C_q' R^-1 C_q)^-1 A_q' + Q``,

with ``R = diag(noise_std^2)`` and ``Q = diag(disturbance_std^2)``, so on a PWA system it depends
on the (unknown) mode sequence.  The observer's matrices are built once, so its weight is one
matrix; this module chooses it so that it never claims more information than a Kalman filter
has, whatever the modes: the information ``Z = W_a' W_a`` with

* ``Z <= Z_0 = diag(1 / initial_std^2)`` (the information of the first prior ``x0``), and
* ``Z <= F_q(Z^-1)^-1`` for every mode ``q``, i.e. the LMI

  ``[[Z, Z A_q, Z Q^(1/2)], [A_q' Z, Z + C_q' R^-1 C_q, 0], [Q^(1/2) Z, 0, I]] >= 0``

  (Schur complements of ``F_q(Z^-1) <= Z^-1`` after the congruence ``diag(Z, I)``; linear in
  ``Z``).

Since each ``F_q`` is monotone, ``P_0 <= Z^-1`` and ``F_q(Z^-1) <= Z^-1`` give by induction
``P_k <= Z^-1`` for every ``k`` and every mode sequence: the prior's stated covariance ``Z^-1``
bounds the Kalman filter's at every window, and ``Z`` is the most informative such matrix in the
sense of the objective (``log det`` of the scaled information, or its trace when some direction
must carry no information at all, e.g. a state unobservable in some mode with process noise).
The LMI is solved by cvxpy with Clarabel as a strict contraction (``F_q(P) <= (1 - margin) P``,
:data:`~hybobs_opt.tolerances.ARRIVAL_CONTRACTION_MARGIN`) and re-checked in numpy with no
tolerance on the invariance (:meth:`ArrivalPrior.verify`): a tolerance per step would accumulate
along a direction whose error never decays.  Such a direction is what model (16) has in backlash
(the twist integrates the unobserved load speed): the LMI has no interior point there, the
solver's answers miss it, and the design is refused with a :class:`~hybobs_opt.errors.SolverError`
rather than certified wrongly (a weight met only to 1e-9 per step was overtaken by the Kalman
filter's own information after 776 backlash steps in the tests' Riccati recursion).

What is proven, and what is not: the bound covers the *Kalman filter's* covariance of the linear
model of each mode; the affine terms and inputs do not change a covariance.  The observer's prior
``x_bar`` is its previous window's estimate, whose data overlap the current window's, and the
modes are those the model's guards allow, not the physical ones: the weight is a conservative
(never over-confident) choice for the linear-Gaussian model, not a proof about the estimator.
``MHEObserver`` states that its ``observable`` flag is then unique *given the prior*
(``info["uniqueness"]["includes_prior"]``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..contract import noise_std_vector
from ..errors import ModelError, SolverError
from ..status import Status
from ..systems.pwa import PWASystem
from ..tolerances import ARRIVAL_CONTRACTION_MARGIN, ARRIVAL_LMI_RTOL
from ..results import Certificate

__all__ = ["ArrivalPrior", "certified_arrival_prior", "std_vector"]


@dataclass(frozen=True, eq=False)
class ArrivalPrior(Certificate):
    """The arrival weight of :func:`certified_arrival_prior` and what it was proven for.

    Parameters
    ----------
    weight : (n, n) ndarray
        ``W_a``, the symmetric square root of ``information`` (pass it, or this object, as the
        ``arrival_weight`` of :class:`~hybobs_opt.mhe.MHEObserver`).
    information : (n, n) ndarray
        ``Z = W_a' W_a``, the information (inverse covariance) the prior claims.
    noise_std, disturbance_std, initial_std : (p,), (n,) or None, (n,) ndarrays
        The noise levels it was tuned for (``disturbance_std`` ``None``: no process noise).
    A, M, Q : tuple of (n, n) ndarrays, (n, n) ndarray or None
        Each mode's ``A_q`` and ``C_q' R^-1 C_q``, and ``Q`` (what :meth:`verify` re-checks).
    objective : {"logdet", "trace"}
        Which objective chose ``Z`` (``"trace"`` when no positive definite ``Z`` exists).
    status : Status
        ``OPTIMAL`` once the numpy re-check passed.
    seconds : float
        Wall time of the design.
    residuals : dict
        Smallest eigenvalue of each re-checked matrix, relative to its scale (negative beyond
        ``-ARRIVAL_LMI_RTOL`` fails :meth:`verify`).

    See Also
    --------
    certified_arrival_prior : computes it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> def rotation(angle):
    ...     return 0.8 * np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    >>> B, C = np.array([[0.0], [1.0]]), np.array([[0.0, 1.0]])
    >>> plant = PWASystem((PWAMode(rotation(0.5), B, np.zeros(2), C, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.zeros(1))),
    ...                    PWAMode(rotation(-0.5), B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0]]), np.zeros(1)))),
    ...                   Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]))
    >>> from hybobs_opt.synthesis import certified_arrival_prior
    >>> prior = certified_arrival_prior(plant, 0.1)
    >>> bool(np.allclose(prior.weight.T @ prior.weight, prior.information))
    True
    >>> prior.noise_std
    array([0.1])
    """

    weight: np.ndarray
    information: np.ndarray
    noise_std: np.ndarray
    disturbance_std: np.ndarray | None
    initial_std: np.ndarray
    A: tuple
    M: tuple
    Q: np.ndarray | None
    objective: str
    status: Status
    seconds: float
    residuals: dict = field(default_factory=dict)

    @property
    def reason(self) -> str:
        """What the prior proves: it never claims more information than a Kalman filter has."""
        return (f"The arrival weight's information Z ({self.objective} design) stays below the Kalman filter's "
                f"information under every one of the {len(self.A)} modes' dynamics and outputs, and below the first "
                "prior's: the prior never claims more than a filter of the stated noise knows (Rao, Rawlings & Lee 2001)")

    def check(self) -> dict[str, float]:
        """The claims of the induction, re-checked in numpy (relative; negative means violated).

        In coordinates scaled by ``S = diag(initial_std)`` (``Z_0`` becomes the identity), with
        ``Z`` the scaled information and ``G`` its symmetric square root:

        * ``"Z"``, ``"Z0 - Z"``: smallest eigenvalues of ``Z`` and ``I - Z``;
        * ``"mode q"`` without process noise: smallest eigenvalue of ``Z + M_q - A_q' Z A_q``
          (``Z <= J`` then gives ``Z <= A_q^-T (J + M_q) A_q^-1``, the next information) over
          the largest eigenvalue of ``Z``; with process noise ``Q``: ``1 -`` the largest
          eigenvalue of ``G (A_q (Z + M_q)^+ A_q' + Q) G``, minus the squared norm of ``G A_q N``
          for ``N`` a basis of the null space of ``Z + M_q`` (directions with no information at
          all, whose image must carry none either).

        The block LMI's own eigenvalues are not used: near a singular ``Z`` they can be tiny
        while the statement above is violated.

        Returns
        -------
        dict of str to float
            One relative margin per claim.
        """
        Z, n = self.information, self.information.shape[0]
        s = self.initial_std
        S, Sinv = np.diag(s), np.diag(1.0 / s)
        Zs = S @ Z @ S
        Zs = 0.5 * (Zs + Zs.T)
        wz = np.linalg.eigvalsh(Zs)
        scale = max(float(np.abs(wz).max()), 1e-300)
        out = {"Z": float(wz.min() / scale), "Z0 - Z": float(np.linalg.eigvalsh(np.eye(n) - Zs).min())}
        G = _sqrt_psd(Zs)
        for q, (A, M) in enumerate(zip(self.A, self.M)):
            As, Ms = Sinv @ A @ S, S @ M @ S
            if self.Q is None:
                D = Zs + Ms - As.T @ Zs @ As
                out[f"mode {q}"] = float(np.linalg.eigvalsh(0.5 * (D + D.T)).min() / scale)
                continue
            Qs = Sinv @ self.Q @ Sinv
            ZM = 0.5 * (Zs + Ms + (Zs + Ms).T)
            w, V = np.linalg.eigh(ZM)
            null = w <= 1e-12 * max(float(np.abs(w).max()), 1e-300)
            inv = (V[:, ~null] / w[~null]) @ V[:, ~null].T
            X = As @ inv @ As.T + Qs
            top = float(np.linalg.eigvalsh(0.5 * (G @ X @ G + (G @ X @ G).T)).max())
            leak = float(np.linalg.norm(G @ As @ V[:, null]) ** 2) if null.any() else 0.0
            out[f"mode {q}"] = 1.0 - top - leak / ARRIVAL_LMI_RTOL
        return out

    def verify(self) -> bool:
        """Whether ``Z`` and ``Z_0 - Z`` are positive semidefinite to ``ARRIVAL_LMI_RTOL`` and every
        mode's invariance holds with no tolerance at all (a per-step tolerance would accumulate).

        Returns
        -------
        bool
            Whether every claim holds.
        """
        out = self.check()
        return bool(all(np.isfinite(v) for v in out.values())
                    and out["Z"] >= -ARRIVAL_LMI_RTOL and out["Z0 - Z"] >= -ARRIVAL_LMI_RTOL
                    and all(v >= 0.0 for k, v in out.items() if k.startswith("mode")))

    def to_dict(self) -> dict:
        """JSON-ready summary (weight, information, noise levels, objective, status, residuals).

        Returns
        -------
        dict
            The summary.
        """
        return {"weight": self.weight.tolist(), "information": self.information.tolist(),
                "noise_std": self.noise_std.tolist(),
                "disturbance_std": None if self.disturbance_std is None else self.disturbance_std.tolist(),
                "initial_std": self.initial_std.tolist(), "objective": self.objective, "status": str(self.status),
                "seconds": self.seconds, "residuals": dict(self.residuals)}


def _lmi_matrix(Z, A, M, Q, lib):
    """The block matrix of the invariance LMI (numpy arrays, or cvxpy expressions with ``lib = cp``)."""
    n = A.shape[0]
    if lib is np:
        top = np.hstack([Z, Z @ A])
        mid = np.hstack([A.T @ Z, Z + M])
        if Q is None:
            return np.vstack([top, mid])
        Qh = _sqrt_psd(Q)
        return np.block([[Z, Z @ A, Z @ Qh], [A.T @ Z, Z + M, np.zeros((n, n))], [Qh @ Z, np.zeros((n, n)), np.eye(n)]])
    zero = np.zeros((n, n))
    if Q is None:
        return lib.bmat([[Z, Z @ A], [A.T @ Z, Z + M]])
    Qh = _sqrt_psd(Q)
    return lib.bmat([[Z, Z @ A, Z @ Qh], [A.T @ Z, Z + M, zero], [Qh @ Z, zero, np.eye(n)]])


def _sqrt_psd(M: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    return (V * np.sqrt(np.maximum(w, 0.0))) @ V.T


def std_vector(value, dim: int, name: str, what: str) -> np.ndarray:
    """``value`` (a positive scalar or a length-``dim`` vector of standard deviations) as a ``(dim,)`` array;
    :class:`ModelError` naming ``name`` and ``what`` the deviations are of otherwise."""
    arr = np.asarray(value, dtype=float) if not isinstance(value, (str, bytes, bool)) else None
    if arr is None or arr.ndim > 1 or (arr.ndim == 1 and arr.size != dim):
        raise ModelError(name, f"a positive scalar or a length-{dim} vector ({what})", repr(value))
    arr = np.full(dim, float(arr)) if arr.ndim == 0 else arr.copy()
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise ModelError(name, f"positive finite standard deviations ({what})", repr(value))
    return arr


def certified_arrival_prior(system: PWASystem, noise_std, *, disturbance_std=None, initial_std=None) -> ArrivalPrior:
    """The most informative arrival weight that no mode sequence's Kalman filter contradicts.

    Solves, with cvxpy and Clarabel, ``max log det(S Z S)`` (or ``trace(S Z S)`` when no positive
    definite ``Z`` is feasible) over ``0 <= Z <= diag(1 / initial_std^2)`` subject to the
    invariance LMI of every mode (module docstring), ``S = diag(initial_std)``; the answer is
    re-checked in numpy before it is returned.

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1 of paper 002); its modes' ``A_q`` and ``C_q`` enter.
    noise_std : float or (p,) array
        Standard deviation of the white Gaussian output noise, per output (as
        ``MHEObserver(noise_std=...)``).
    disturbance_std : float or (n,) array, optional
        Standard deviation of a white Gaussian state disturbance ``w(k)`` (the matching
        ``disturbance_weight`` of the observer is ``1 / disturbance_std``); ``None``: none.
    initial_std : float or (n,) array, optional
        Standard deviation of the error of the first prior (the ``x0`` given to
        :meth:`~hybobs_opt.mhe.MHEObserver.reset`).  Default: that of a uniform distribution over
        the state box, ``half-width / sqrt(3)`` (the observer's default ``x0`` is the box's
        centre).

    Returns
    -------
    ArrivalPrior
        ``weight`` (``W_a``) and ``information`` (``W_a' W_a``), verified.

    Raises
    ------
    ModelError
        A system that is not a bounded :class:`~hybobs_opt.systems.pwa.PWASystem`, or a noise level
        that is not positive and finite.
    SolverError
        When Clarabel (and the fallback solvers) return no point that passes the re-check: the
        message names the problem and what to try.

    See Also
    --------
    ArrivalPrior : what it returns.
    hybobs_opt.mhe.MHEObserver : its arrival cost.

    Examples
    --------
    Two rotating modes split at ``x1 = 0``, observed through ``x2`` with noise 0.1:

    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> def rotation(angle):
    ...     return 0.8 * np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    >>> B, C = np.array([[0.0], [1.0]]), np.array([[0.0, 1.0]])
    >>> plant = PWASystem((PWAMode(rotation(0.5), B, np.zeros(2), C, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.zeros(1))),
    ...                    PWAMode(rotation(-0.5), B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0]]), np.zeros(1)))),
    ...                   Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]))
    >>> from hybobs_opt.synthesis import certified_arrival_prior
    >>> prior = certified_arrival_prior(plant, 0.1)
    >>> prior.objective, prior.status.value, prior.verify()
    ('logdet', 'optimal', True)
    >>> prior.weight.shape                             # the arrival cost is ||weight (x - x_prior)||^2
    (2, 2)
    """
    import cvxpy as cp

    from ..lmi.solve import solve_problem

    t0 = time.perf_counter()
    if not isinstance(system, PWASystem):
        raise ModelError("system", "a PWASystem", type(system).__name__)
    n, p = system.n, system.p
    sigma = noise_std_vector(noise_std, p)
    half = system.scales()[0][:n]
    if initial_std is None:
        if not np.all(np.isfinite(half) & (half > 0)):
            raise ModelError("initial_std", "given when the state box is unbounded or flat", repr(half.tolist()))
        s0 = half / np.sqrt(3.0)
    else:
        s0 = std_vector(initial_std, n, "initial_std", "of the first prior's error, per state")
    sw = None if disturbance_std is None else std_vector(disturbance_std, n, "disturbance_std",
                                                           "of the state disturbance, per state")
    Rinv = np.diag(1.0 / sigma ** 2)
    As = tuple(np.asarray(md.A, dtype=float) for md in system.modes)
    Ms = tuple(md.C.T @ Rinv @ md.C for md in system.modes)
    Q = None if sw is None else np.diag(sw ** 2)
    # scaled coordinates xi = x / s0: Z_0 becomes the identity and the LMI entries are O(1)
    S, Sinv = np.diag(s0), np.diag(1.0 / s0)
    Qs = None if Q is None else Sinv @ Q @ Sinv
    Zs = cp.Variable((n, n), symmetric=True)
    cons = [Zs >> 0, np.eye(n) - Zs >> 0]
    for A, M in zip(As, Ms):
        # the top-left Z shrunk to (1 - margin) Z: F_q(P) <= (1 - margin) P, a strict contraction
        # whose slack absorbs the solver's tolerance (an invariance met only to 1e-9 per step
        # drifts without bound along a direction whose error never decays)
        block = _lmi_matrix(Zs, Sinv @ A @ S, S @ M @ S, Qs, cp)
        n2 = block.shape[0]
        shrink = np.zeros((n2, n2))
        shrink[:n, :n] = 1.0
        cons.append(0.5 * (block + block.T) - ARRIVAL_CONTRACTION_MARGIN * cp.multiply(shrink, block) >> 0)
    results = []
    for objective in ("logdet", "trace"):
        expr = cp.log_det(Zs) if objective == "logdet" else cp.trace(Zs)
        problem = cp.Problem(cp.Maximize(expr), cons)
        outcome = solve_problem(problem)
        results.append((objective, outcome.status, str(outcome.attempts)))
        if Zs.value is None or outcome.status not in (Status.OPTIMAL, Status.OPTIMAL_INACCURATE):
            continue
        Zval = 0.5 * (Zs.value + Zs.value.T)
        if objective == "logdet" and np.linalg.eigvalsh(Zval).min() <= ARRIVAL_LMI_RTOL:
            continue  # log det at its boundary: some direction must carry no information
        w, V = np.linalg.eigh(Zval)
        # directions the solver left at the level of its tolerance carry no information
        w = np.where(w > ARRIVAL_LMI_RTOL * max(float(w.max()), 1e-300), w, 0.0)
        info = Sinv @ ((V * w) @ V.T) @ Sinv
        info = 0.5 * (info + info.T)
        weight = _sqrt_psd(info)
        prior = ArrivalPrior(weight=weight, information=info, noise_std=sigma, disturbance_std=sw, initial_std=s0,
                             A=As, M=Ms, Q=Q, objective=objective, status=Status.OPTIMAL,
                             seconds=time.perf_counter() - t0)
        residuals = prior.check()
        object.__setattr__(prior, "residuals", residuals)
        if prior.verify():
            return prior
        results[-1] = (objective, Status.RECHECK_FAILED, f"residuals {residuals}")
    raise SolverError(f"arrival-cost LMI of {system.n_modes} modes (certified_arrival_prior)", "CLARABEL",
                      "; ".join(f"{o}: {s} {a}" for o, s, a in results),
                      "a larger disturbance_std: a mode with an unobservable direction whose error does not "
                      "decay (the backlash of model (16): the twist integrates the load speed) leaves the "
                      "LMI no interior point along it, and the solver's answer then misses it by more "
                      "than the re-check allows")
