"""Noise-to-error gain: a certified ultimate bound on the estimation error under bounded noise.

Paper 004's observer ``x^' = A x^ + F f(E x^) + B u + g(y, u) + L (y - h(C x^))`` is designed
there for exact measurements.  Here the measured output carries noise, ``y_m = h(C x) + v`` with
``|v_j| <= vbar_j`` per output, and the plant optionally a process disturbance ``W w`` with
``|w_i| <= wbar_i``.  By the mean-value theorem applied to each scalar function (paper 004, eqs.
4-5) the error ``e = x - x^`` obeys

.. math::

    \\dot e = (A + F \\Theta E - L C_\\mu)\\, e - L\\,\\mathrm{diag}(\\bar v)\\, \\nu + W \\mathrm{diag}(\\bar w)\\, \\omega,
    \\qquad |\\nu_j| \\le 1,\\ |\\omega_i| \\le 1,

with slopes ``Theta(t)``, ``mu(t)`` in the Jacobian box, as long as ``x`` and ``x^`` both stay in
the region the box was computed on (the mean-value slope between them is then a slope of the
region).  The right-hand side is affine in the slopes, so it suffices to ask at each vertex
``(A_v, C_v)`` of the box (:mod:`.polytopic`), for ``V = e' P e`` and ``Y = P L``:

.. math::

    \\begin{bmatrix}
      He(P A_v - Y C_v) + \\alpha P & -Y \\mathrm{diag}(\\bar v) & P W \\mathrm{diag}(\\bar w) \\\\
      \\ast & -\\mathrm{diag}(\\mu_v) & 0 \\\\
      \\ast & 0 & -\\mathrm{diag}(\\mu_w)
    \\end{bmatrix} \\preceq 0,
    \\qquad \\mu \\ge 0,\\ \\textstyle\\sum_j \\mu_j = \\alpha .

It is the quadratic form of ``V' + alpha V - sum_j mu_j nu_j^2`` in ``(e, nu, omega)``, so along
every trajectory ``V' <= -alpha V + sum_j mu_j = -alpha (V - 1)``: ``V(t) <= 1 + e^{-alpha t}
max(V(0) - 1, 0)``.  The ellipsoid ``e' P e <= 1`` is invariant and attracts every error, and
without noise ``V`` decays at rate ``alpha`` (the ``sigma`` of :mod:`.decay_design`).  By
Cauchy-Schwarz, ``|e_k| <= sqrt((P^-1)_kk)`` on it: the per-state ultimate bound, in the model's
units.  This is the invariant-ellipsoid (peak-to-peak) bound of S. Boyd, L. El Ghaoui, E. Feron
and V. Balakrishnan, *Linear Matrix Inequalities in System and Control Theory*, SIAM 1994,
Sec. 6.1.3, and of J. Abedor, K. Nagpal and K. Poolla, "A linear matrix inequality approach to
peak-to-peak gain minimization", Int. J. Robust Nonlinear Control 6(9-10), 1996, here with one
``P`` on every vertex of paper 004's Jacobian box.

One multiplier ``mu_j`` per noise channel (``multipliers="per_channel"``) weighs each bound
``nu_j^2 <= 1`` on its own; ``"pooled"`` fixes ``mu_j = alpha / q`` for the ``q`` channels, i.e.
uses only ``|nu|^2 + |omega|^2 <= q`` (the bound scaled: ``e' P e <= q`` with ``-alpha I`` in the
blocks).  Pooled is a special case of per-channel, so per-channel's bound is never larger; for a
scalar error it is exact (:func:`noise_optimal_design`'s tests compare it with the closed form).

For a fixed ``alpha`` the blocks are LMIs in ``(P, Y, mu)``.  The bound is minimised relative to a
reference size per state ``s_k`` (default the half-widths of the operating box): ``[[P, I], [I, B]]
>= 0`` gives ``(P^-1)_kk <= B_kk`` and the SDP minimises ``t`` with ``B_kk <= t s_k^2``.  The decay
rate is searched outside (a grid and a golden-section refinement over ``log alpha``; only ``alpha
>= min_decay`` when a rate is required).  The noise LMI is feasible at ``alpha`` when the polytopic
condition holds strictly at decay rate ``alpha`` (scale ``P`` and ``Y`` down until the noise terms
fit), and only if it holds non-strictly, so the search runs up to the polytopic condition's
largest rate ``sigma_max`` (:meth:`.polytopic.PolytopicLMI.max_decay`), and a required rate no gain
reaches is refused with that condition's certificate of infeasibility.  An optional bound
``||L||_2 <= l`` uses the sufficient form of :mod:`.observer_lmi` with a free multiplier
(``P >= kappa I``, ``[[P, Y], [Y', kappa l^2 I]] >= 0``, in the box-scaled coordinates); as in
:mod:`.decay_design`, the internal bound is then raised while the gain's own norm stays within
``l``.

Nothing the solver returns is trusted: at its point the blocks are recomputed in numpy with the
gain ``L = P^-1 Y`` that is delivered, their largest eigenvalue made negative by lowering
``alpha`` and raising the ``mu_j`` by what the solver missed (at most a relative
:data:`~hybobs_opt.tolerances.NOISE_LMI_REPAIR_RTOL`, so the ellipsoid's level ``sum(mu) /
alpha`` is 1 up to that), and the bound recomputed from ``P`` and that level.
:meth:`NoiseBoundDesign.verify` re-does this check in numpy.
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from .._validate import as_positive
from ..errors import InfeasibleError, ModelError, SolverError
from ..results import Certificate
from ..status import Status
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import GAIN_BOUND_RTOL, NOISE_BOUND_RECHECK_RTOL, NOISE_LMI_REPAIR_RTOL, NOISE_LMI_ROUNDING_RTOL
from .bounds import JacobianBounds
from .lmi_model import box_scaling, lmi_data
from .polytopic import vertex_matrices, vertex_slopes
from .solve import POINT_STATUSES, SOLVER, solve_problem

__all__ = ["NOISE_MULTIPLIERS", "NoiseBoundCheck", "NoiseBoundDesign", "NoiseGainLMI", "NoiseTradeoff",
           "noise_optimal_design", "noise_tradeoff", "noise_vertex_blocks"]

#: The multiplier layouts of :class:`NoiseGainLMI` (see the module docstring).
NOISE_MULTIPLIERS = ("per_channel", "pooled")


# ---------------------------------------------------------------------------- numpy model
def _output_order(system: ScalarNonlinearSystem) -> np.ndarray:
    """Output indices in the order of the rows of ``C_v`` (linear outputs first, as :mod:`.polytopic`)."""
    lin = np.array(system.linear_outputs, dtype=bool)
    return np.concatenate([np.nonzero(lin)[0], np.nonzero(~lin)[0]]).astype(int)


def _scaled_vertices(system: ScalarNonlinearSystem, bounds: JacobianBounds, d: np.ndarray):
    """Vertex matrices ``(A_v, C_v)`` of ``bounds`` in the coordinates ``x = diag(d) x_bar``."""
    return vertex_matrices(lmi_data(system).scaled(d), vertex_slopes(bounds))


def noise_vertex_blocks(P_bar: np.ndarray, L_bar: np.ndarray, alpha: float, mu: np.ndarray, As, Cs,
                        v_bar: np.ndarray, W_bar: np.ndarray) -> list[np.ndarray]:
    """The vertex blocks of the noise LMI at a point, in numpy, in balanced coordinates.

    The blocks of the module docstring with ``Y = P L``, written with the gain itself
    (``He(P (A_v - L C_v))``, ``-P L diag(vbar)``).  They are returned after the congruence
    ``blkdiag(r I, I)`` with ``r = lambda_max(P)^{-1/2}``, which leaves their signs unchanged and
    brings ``P`` to norm one, so that the eigenvalues of the ``e`` and the noise directions are
    compared on one scale (``P`` itself scales as the inverse square of the noise).

    Parameters
    ----------
    P_bar : (n, n) array
        ``P`` in the scaled coordinates (positive definite).
    L_bar : (n, p) array
        The gain in the scaled coordinates, columns in the order of the rows of ``C_v``.
    alpha : float
        Decay rate of ``V``.
    mu : (p + m,) array
        Multipliers of the output-noise channels, then of the disturbance channels.
    As, Cs : list of arrays
        Vertex matrices (scaled coordinates).
    v_bar : (p,) array
        Noise bounds, in the order of the rows of ``C_v``.
    W_bar : (n, m) array
        ``diag(d)^-1 W diag(wbar)`` (``m = 0``: no disturbance).

    Returns
    -------
    list of (n + p + m, n + p + m) arrays
        One symmetric block per vertex.
    """
    P_bar = 0.5 * (P_bar + P_bar.T)
    s = float(np.linalg.eigvalsh(P_bar)[-1])
    Pt, k = P_bar / s, math.sqrt(s)
    n, p, m = P_bar.shape[0], L_bar.shape[1], W_bar.shape[1]
    noise = -(Pt @ L_bar) * (v_bar * k)[None, :]
    dist = (Pt @ W_bar) * k
    out = []
    for A, C in zip(As, Cs):
        Acl = A - L_bar @ C
        B = np.zeros((n + p + m, n + p + m))
        B[:n, :n] = Pt @ Acl + Acl.T @ Pt + alpha * Pt
        B[:n, n:n + p], B[n:n + p, :n] = noise, noise.T
        B[:n, n + p:], B[n + p:, :n] = dist, dist.T
        B[n:, n:] = -np.diag(mu)
        out.append(0.5 * (B + B.T))
    return out


def _repair(P_bar, L_bar, alpha, mu, As, Cs, v_bar, W_bar):
    """``(alpha, mu, blocks)`` with every block's largest eigenvalue at most ``-rounding`` (numpy).

    The blocks are lowered by ``blkdiag(delta P, eps I)`` (balanced coordinates): ``alpha`` falls by
    ``delta`` and every ``mu_j`` rises by ``eps``, which lowers each block by at least
    ``min(delta lambda_min(P), eps)``; both are chosen to absorb the largest eigenvalue plus
    :data:`~hybobs_opt.tolerances.NOISE_LMI_ROUNDING_RTOL` times the blocks' norm (so numpy's own
    rounding cannot flip the sign of the re-check).
    """
    mu = np.asarray(mu, dtype=float).copy()
    P_bar = 0.5 * (P_bar + P_bar.T)
    w = np.linalg.eigvalsh(P_bar)
    lam_min = float(w[0] / w[-1])  # of the balanced P (norm one)
    for _ in range(3):
        blocks = noise_vertex_blocks(P_bar, L_bar, alpha, mu, As, Cs, v_bar, W_bar)
        scale = max(float(np.linalg.norm(B, 2)) for B in blocks)
        top = max(float(np.linalg.eigvalsh(B)[-1]) for B in blocks)
        need = top + 2.0 * NOISE_LMI_ROUNDING_RTOL * scale
        if need <= 0.0:
            return alpha, mu, blocks
        alpha = alpha - need / lam_min
        mu = mu + need
    return alpha, mu, noise_vertex_blocks(P_bar, L_bar, alpha, mu, As, Cs, v_bar, W_bar)


def _bounds_from(P_bar: np.ndarray, d: np.ndarray, level: float) -> np.ndarray:
    """``sqrt(level (P^-1)_kk)`` in model units (``P^-1 = diag(d) P_bar^-1 diag(d)``)."""
    Pinv = np.linalg.inv(0.5 * (P_bar + P_bar.T))
    return np.sqrt(level * np.clip(np.diag(Pinv), 0.0, None)) * d


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class NoiseBoundCheck:
    """The numpy re-check of a :class:`NoiseBoundDesign`.

    Attributes
    ----------
    ok : bool
        Every item below holds.
    vertex_max_eig : tuple of float
        Largest eigenvalue of each vertex block (balanced coordinates); each must be ``<= 0``.
    p_min_eig : float
        Smallest eigenvalue of the scaled ``P`` (must be ``> 0``).
    bound_residual : float
        Largest relative difference between the stated per-state bound and ``sqrt(level (P^-1)_kk)``
        recomputed from ``P`` (at most :data:`~hybobs_opt.tolerances.NOISE_BOUND_RECHECK_RTOL`).
    level_residual : float
        ``|level - sum(mu) / alpha| / level``.
    gain_norm : float
        ``||L||_2`` (within the gain bound, when there is one).
    messages : tuple of str
        What failed.
    """

    ok: bool
    vertex_max_eig: tuple[float, ...]
    p_min_eig: float
    bound_residual: float
    level_residual: float
    gain_norm: float
    messages: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return {"ok": self.ok, "vertex_max_eig": list(self.vertex_max_eig), "p_min_eig": self.p_min_eig,
                "bound_residual": self.bound_residual, "level_residual": self.level_residual,
                "gain_norm": self.gain_norm, "messages": list(self.messages)}


@dataclass(frozen=True)
class NoiseBoundDesign(Certificate):
    """A gain with a certified ultimate bound on the estimation error under bounded noise.

    It is its own certificate (:class:`~hybobs_opt.results.Certificate`): ``P``, ``mu`` and ``alpha``
    are the evidence, :meth:`verify` re-checks them in numpy.

    The claim (module docstring): while the plant state and the estimate stay in the region of
    ``bounds``, ``V = e' P e`` obeys ``V' <= -alpha (V - level)``, so the error enters the ellipsoid
    ``e' P e <= level`` and stays there, and then ``|e_k| <= bound[k]`` for every output noise
    ``|v_j| <= noise[j]`` (and disturbance ``|w_i| <= disturbance[i]``).

    Parameters
    ----------
    feasible : bool
        The point passed the numpy re-check (only then are the fields below a claim).
    status : Status
        The solver's status, or :attr:`~hybobs_opt.status.Status.RECHECK_FAILED`.
    L, P : arrays or None
        Gain (``n x p``, columns in output order) and Lyapunov matrix, model coordinates.
    alpha : float
        Decay rate of ``V`` proven with these ``P``, ``L`` (after the numpy repair; at most the
        rate the SDP was solved at).
    mu : (p + m,) array or None
        Multipliers of the noise channels (outputs, then disturbances).
    level : float
        ``sum(mu) / alpha``: the invariant ellipsoid is ``e' P e <= level`` (1 up to the repair).
    bound : (n,) array or None
        Per-state ultimate bound ``sqrt(level (P^-1)_kk)`` in the model's units.
    reference : (n,) array
        The per-state sizes the worst bound is measured against (:attr:`worst_relative`).
    noise : (p,) array
        Output-noise bounds ``vbar`` (output order, model units).
    disturbance : (m,) array
        Disturbance bounds ``wbar`` (empty without a disturbance).
    W : (n, m) array
        How the disturbance enters the state equation.
    gain_bound : float or None
        Bound imposed on ``||L||_2``.
    gain_norm : float or None
        ``||L||_2``.
    multipliers : str
        ``"per_channel"`` or ``"pooled"``.
    internal_gain_bound : float or None
        The bound the LMI was solved with: at least ``gain_bound``, raised while the gain's own norm
        stays within ``gain_bound`` (the LMI's bound is sufficient, not necessary).
    lmi_max_eig : tuple of float
        The re-check's largest eigenvalue per vertex block (each ``<= 0``).
    p_min_eig : float or None
        Smallest eigenvalue of the scaled ``P``.
    alpha_solved : float
        The rate the SDP was solved at (``alpha`` is below it by the repair only).
    seconds : float
        Wall time of the design (the whole search for :func:`noise_optimal_design`).
    search : tuple of (alpha, worst relative bound, status)
        Every rate solved, in order (``nan`` where no checked bound came out).
    scaling : (n,) array
        The state scaling of the LMI.
    system, bounds
        What :meth:`verify` re-checks against.

    See Also
    --------
    noise_optimal_design : Returns one.
    noise_tradeoff : Designs at several decay rates.
    switched_noise_bound : The bound of a switched observer.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import noise_optimal_design
    >>> design = noise_optimal_design(pendulum, bounds, [0.01], gain_bound=10.0, alpha=0.5)
    >>> design.feasible, design.L.shape
    (True, (2, 1))
    >>> np.round(design.bound, 4)
    array([0.0174, 0.0174])
    >>> design.verify()
    True
    """

    feasible: bool
    status: str
    L: np.ndarray | None
    P: np.ndarray | None
    alpha: float
    mu: np.ndarray | None
    level: float
    bound: np.ndarray | None
    reference: np.ndarray
    noise: np.ndarray
    disturbance: np.ndarray
    W: np.ndarray
    gain_bound: float | None
    gain_norm: float | None
    multipliers: str
    internal_gain_bound: float | None = None
    lmi_max_eig: tuple[float, ...] = ()
    p_min_eig: float | None = None
    alpha_solved: float = float("nan")
    seconds: float = 0.0
    search: tuple[tuple[float, float, str], ...] = ()
    scaling: np.ndarray = field(default=None, repr=False)
    system: ScalarNonlinearSystem = field(default=None, repr=False)
    bounds: JacobianBounds = field(default=None, repr=False)

    #: The result the evidence applies (the attribute of every certificate of the package).
    theorem = "invariant ellipsoid under bounded noise (peak-to-peak bound) on the polytopic Jacobian box"

    @property
    def reason(self) -> str:
        """The claim and its mechanism, for this design."""
        if not self.feasible or self.bound is None:
            return f"no noise-bound design (status {self.status})"
        bounds = ", ".join(f"{b:.4g}" for b in self.bound)
        names = ", ".join(self.system.state_names) if self.system is not None else "the states"
        dist = "" if not self.disturbance.size else (
            f" and disturbance |w_i| <= {np.array2string(self.disturbance, precision=4)}")
        return (f"V = e'Pe with V' + alpha V - sum_j mu_j nu_j^2 <= 0 at every vertex of the Jacobian box (alpha = "
                f"{self.alpha:.4g}; verify() re-checks the vertex blocks in numpy): for output noise "
                f"|v_j| <= {np.array2string(self.noise, precision=4)}{dist} the error enters and stays in e'Pe <= "
                f"{self.level:.6g}, where |e_k| <= ({bounds}) for ({names}), as long as the state and the estimate "
                f"stay in the region of the box")

    @property
    def peak_to_peak_gain(self) -> np.ndarray | None:
        """Per state, the bound per unit of the largest output-noise bound (``None`` with a disturbance).

        The design is linear in the noise (``P`` scales as its inverse square), so for the same
        gain a noise ``c vbar`` gives the bound ``c bound``: this is the peak-to-peak gain from the
        output noise to each error component.
        """
        top = float(np.max(self.noise)) if self.noise.size else 0.0
        if self.bound is None or self.disturbance.size or top <= 0.0:
            return None
        return self.bound / top

    @property
    def relative_bound(self) -> np.ndarray | None:
        """``bound / reference`` per state."""
        return None if self.bound is None else self.bound / self.reference

    @property
    def worst_relative(self) -> float:
        """The largest ``bound[k] / reference[k]`` (what the design minimises); ``inf`` without a design."""
        return float(np.max(self.relative_bound)) if self.feasible and self.bound is not None else float("inf")

    @property
    def residuals(self) -> dict[str, float]:
        """The numpy re-check at the returned point: ``lmi_max_eig`` (``<= 0``), ``p_min_eig`` (``> 0``)."""
        out = {}
        if self.lmi_max_eig:
            out["lmi_max_eig"] = max(self.lmi_max_eig)
        if self.p_min_eig is not None:
            out["p_min_eig"] = self.p_min_eig
        return out

    def lyapunov(self, e: np.ndarray) -> np.ndarray:
        """``V = e' P e`` for errors ``e`` of shape ``(n,)`` or ``(N, n)`` (model units).

        Returns
        -------
        ndarray
            ``V = e' P e`` for errors ``e`` of shape ``(n,)`` or ``(N, n)`` (model units).
        """
        E = np.atleast_2d(np.asarray(e, dtype=float))
        out = np.einsum("ij,jk,ik->i", E, self.P, E)
        return out[0] if np.ndim(e) == 1 else out

    def envelope(self, t: np.ndarray, e0: np.ndarray) -> np.ndarray:
        """Certified per-state bound at times ``t`` from the initial error ``e0``: ``(len(t), n)``.

        ``|e_k(t)| <= sqrt((P^-1)_kk (level + e^{-alpha t} max(V(e0) - level, 0)))`` (module docstring).

        Returns
        -------
        ndarray
            Certified per-state bound at times ``t`` from the initial error ``e0``: ``(len(t), n)``.
        """
        t = np.asarray(t, dtype=float).reshape(-1)
        excess = max(float(self.lyapunov(np.asarray(e0, dtype=float))) - self.level, 0.0)
        scale = np.sqrt((self.level + np.exp(-self.alpha * t) * excess) / self.level)
        return scale[:, None] * self.bound[None, :]

    def transient_time(self, e0: np.ndarray, fraction: float = 0.01) -> float:
        """Time after which the initial error's share of :meth:`envelope` is below ``fraction`` of the bound.

        The share is ``sqrt(e^{-alpha t} V(e0) / level)`` times the bound (the bound of the
        noise-free error from ``e0``); it is below ``fraction`` from ``t = ln(V(e0) / (fraction^2
        level)) / alpha`` on (0 when it is below from the start).

        Parameters
        ----------
        e0 : (n,) array
            Initial error, model units.
        fraction : float, default 0.01
            The share of the bound that counts as decayed.

        Returns
        -------
        float
            Time after which the initial error's share of :meth:`envelope` is below ``fraction``
            of the bound.
        """
        v0 = float(self.lyapunov(np.asarray(e0, dtype=float)))
        target = fraction ** 2 * self.level
        return 0.0 if v0 <= target else math.log(v0 / target) / self.alpha

    def check(self) -> NoiseBoundCheck:
        """Re-check the design in numpy against the vertices of its Jacobian box (no solver).

        Returns
        -------
        NoiseBoundCheck
            Re-check the design in numpy against the vertices of its Jacobian box (no solver).
        """
        msgs: list[str] = []
        nan = float("nan")
        if self.L is None or self.P is None or self.mu is None or self.bound is None:
            return NoiseBoundCheck(False, (), nan, nan, nan, nan, ("no design",))
        arrays = (self.L, self.P, self.mu, self.bound)
        if not all(np.all(np.isfinite(a)) for a in arrays) or not (np.isfinite(self.alpha) and np.isfinite(self.level)):
            return NoiseBoundCheck(False, (), nan, nan, nan, nan, ("a value is not finite",))
        d = self.scaling
        P_bar = d[:, None] * self.P * d[None, :]
        P_bar = 0.5 * (P_bar + P_bar.T)
        p_min = float(np.linalg.eigvalsh(P_bar)[0])
        gain = float(np.linalg.norm(self.L, 2))
        if p_min <= 0.0:
            return NoiseBoundCheck(False, (), p_min, nan, nan, gain, (f"P is not positive definite ({p_min:.3g})",))
        if self.alpha <= 0.0:
            msgs.append(f"the decay rate {self.alpha:.3g} is not positive")
        if np.any(self.mu < 0.0):
            msgs.append(f"a multiplier is negative ({float(self.mu.min()):.3g})")
        order = _output_order(self.system)
        As, Cs = _scaled_vertices(self.system, self.bounds, d)
        L_bar = self.L[:, order] / d[:, None]
        W_bar = (self.W * self.disturbance[None, :]) / d[:, None] if self.W.size else np.zeros((d.size, 0))
        blocks = noise_vertex_blocks(P_bar, L_bar, self.alpha, self.mu, As, Cs, self.noise[order], W_bar)
        eigs = tuple(float(np.linalg.eigvalsh(B)[-1]) for B in blocks)
        if max(eigs) > 0.0:
            msgs.append(f"a vertex block is not negative semidefinite: largest eigenvalue {max(eigs):.3g}")
        level = float(np.sum(self.mu)) / self.alpha if self.alpha > 0 else nan
        level_res = abs(self.level - level) / self.level if self.level > 0 else nan
        if not level_res <= NOISE_BOUND_RECHECK_RTOL:
            msgs.append(f"the level {self.level:.6g} is not sum(mu)/alpha = {level:.6g}")
        ref = _bounds_from(P_bar, d, self.level)
        bound_res = float(np.max(np.abs(self.bound - ref) / np.maximum(ref, np.finfo(float).tiny)))
        if not bound_res <= NOISE_BOUND_RECHECK_RTOL:
            msgs.append(f"the stated bound differs from sqrt(level (P^-1)_kk) by {bound_res:.3g} (relative)")
        if self.gain_bound is not None and gain > self.gain_bound * (1 + GAIN_BOUND_RTOL):
            msgs.append(f"||L||_2 = {gain:.6g} exceeds the gain bound {self.gain_bound:.6g}")
        return NoiseBoundCheck(not msgs, eigs, p_min, bound_res, level_res, gain, tuple(msgs))

    def verify(self) -> bool:
        """True when :meth:`check` confirms the design in numpy.

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        return self.check().ok

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        def arr(a):
            return None if a is None else np.asarray(a).tolist()

        return {"feasible": self.feasible, "status": str(self.status), "alpha": self.alpha,
                "alpha_solved": self.alpha_solved, "level": self.level, "bound": arr(self.bound),
                "peak_to_peak_gain": arr(self.peak_to_peak_gain),
                "relative_bound": arr(self.relative_bound),
                "worst_relative": self.worst_relative if self.feasible else None, "reference": arr(self.reference),
                "noise": arr(self.noise), "disturbance": arr(self.disturbance), "W": arr(self.W),
                "L": arr(self.L), "P": arr(self.P), "mu": arr(self.mu), "gain_bound": self.gain_bound,
                "gain_norm": self.gain_norm, "internal_gain_bound": self.internal_gain_bound,
                "multipliers": self.multipliers,
                "lmi_max_eig": list(self.lmi_max_eig), "p_min_eig": self.p_min_eig, "seconds": self.seconds,
                "search": [{"alpha": a, "worst_relative": None if not np.isfinite(b) else b, "status": s}
                           for a, b, s in self.search],
                "region": None if self.bounds is None or self.bounds.region is None else self.bounds.region.to_dict()}


@dataclass(frozen=True)
class NoiseTradeoff:
    """The smallest certified bound at each of a list of decay rates (:func:`noise_tradeoff`).

    Attributes
    ----------
    alpha : (K,) array
        The decay rates of ``V`` asked for.
    alpha_certified : (K,) array
        The rate each design proves (``nan`` where none was found).
    worst_relative : (K,) array
        The largest per-state bound relative to the reference sizes (``nan`` where none).
    bound : (K, n) array
        Per-state bounds, model units (``nan`` rows where none).
    gain_norm : (K,) array
        ``||L||_2`` of each design.
    feasible : (K,) bool array
    designs : tuple of NoiseBoundDesign

    See Also
    --------
    noise_tradeoff : Returns one.
    plot_noise_tradeoff : Draws it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import noise_tradeoff
    >>> curve = noise_tradeoff(pendulum, bounds, [0.01], [0.1, 0.5, 1.0], gain_bound=10.0)
    >>> curve.feasible
    array([ True,  True,  True])
    >>> np.round(curve.bound, 4)
    array([[0.0267, 0.0244],
           [0.0174, 0.0174],
           [0.0158, 0.0188]])
    """

    alpha: np.ndarray
    alpha_certified: np.ndarray
    worst_relative: np.ndarray
    bound: np.ndarray
    gain_norm: np.ndarray
    feasible: np.ndarray
    designs: tuple = field(repr=False, default=())

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        def clean(a):
            return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, dtype=float).reshape(-1)]

        return {"alpha": clean(self.alpha), "alpha_certified": clean(self.alpha_certified),
                "worst_relative": clean(self.worst_relative),
                "bound": [clean(row) for row in self.bound], "gain_norm": clean(self.gain_norm),
                "feasible": [bool(f) for f in self.feasible]}


# ---------------------------------------------------------------------------- the compiled LMI
_COMPILED: "weakref.WeakKeyDictionary[ScalarNonlinearSystem, dict]" = weakref.WeakKeyDictionary()


class NoiseGainLMI:
    """The noise LMI of one system for a fixed ``alpha``, compiled once with cvxpy ``Parameter`` objects.

    The vertex matrices, ``alpha``, the noise and disturbance columns, the reference sizes and the
    gain bound are parameters; each solve only substitutes them.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004 (without ``g(y, u)``: noise on ``y`` would enter
        through it, which the LMI does not bound).
    n_disturbance : int, default 0
        Number of disturbance channels ``m``.
    gain_bound : float, optional
        ``||L||_2 <= gain_bound`` (model units) by the sufficient form of the module docstring.
    scaling : (n,) array, optional
        State scaling (default: the box half-widths).
    multipliers : {"per_channel", "pooled"}
        See the module docstring.
    fixed_gain : bool, default False
        Analyse a given gain instead of designing one: ``Y = P L`` with ``L`` a parameter (set by
        :meth:`solve`'s ``gain``), so the blocks are LMIs in ``(P, mu)`` alone.

    Raises
    ------
    ModelError
        A system with ``g(y, u)``, too many vertices, a bad scaling or multiplier layout, or a gain
        bound with a fixed gain.
    """

    def __init__(self, system: ScalarNonlinearSystem, *, n_disturbance: int = 0, gain_bound: float | None = None,
                 scaling: np.ndarray | None = None, multipliers: str = "per_channel", fixed_gain: bool = False):
        from ..defaults import POLYTOPIC_MAX_VERTICES

        if not isinstance(system, ScalarNonlinearSystem):
            raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
        if system.g is not None:
            raise ModelError("system.g", "no g(y, u) term (the measured output's noise would enter the error through "
                             "g, which the noise LMI does not bound)", "a callable")
        if multipliers not in NOISE_MULTIPLIERS:
            raise ModelError("multipliers", f"one of {NOISE_MULTIPLIERS}", repr(multipliers))
        self.system = system
        self.multipliers = multipliers
        self.m = int(n_disturbance)
        self.d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        if self.d.shape != (system.n,) or not np.all(np.isfinite(self.d) & (self.d > 0)):
            raise ModelError("scaling", f"{system.n} positive numbers", repr(scaling))
        data = lmi_data(system)
        k = data.r + data.p_nl
        if 2 ** k > POLYTOPIC_MAX_VERTICES:
            raise ModelError("system", f"at most {POLYTOPIC_MAX_VERTICES} vertices of the Jacobian box",
                             f"2^{k} = {2 ** k}")
        self.n_vertices = 2 ** k
        self.order = _output_order(system)
        self.gain_bound = None if gain_bound is None else float(gain_bound)
        self.fixed_gain = bool(fixed_gain)
        if self.fixed_gain and self.gain_bound is not None:
            raise ModelError("gain_bound", "no bound with a fixed gain (the gain is given)", repr(gain_bound))
        self._build()

    @classmethod
    def compiled(cls, system: ScalarNonlinearSystem, *, n_disturbance: int = 0, gain_bound: float | None = None,
                 scaling: np.ndarray | None = None, multipliers: str = "per_channel",
                 fixed_gain: bool = False) -> "NoiseGainLMI":
        """The process-wide compiled LMI (keyed by the system, the sizes, the scaling and the layout).

        Parameters
        ----------
        system : ScalarNonlinearSystem
            The cache key (held weakly).
        n_disturbance, gain_bound, scaling, multipliers, fixed_gain
            As for :class:`NoiseGainLMI`; the gain bound's value is set on every call.
        """
        d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        key = (int(n_disturbance), gain_bound is None, d.tobytes(), multipliers, bool(fixed_gain))
        per = _COMPILED.setdefault(system, {})
        obj = per.get(key)
        if obj is None:
            obj = per[key] = cls(system, n_disturbance=n_disturbance, gain_bound=gain_bound, scaling=d,
                                 multipliers=multipliers, fixed_gain=fixed_gain)
        elif gain_bound is not None:
            obj.set_gain_bound(gain_bound)
        return obj

    def _build(self) -> None:
        n, p, m = self.system.n, self.system.p, self.m
        q = p + m
        self.P = cp.Variable((n, n), symmetric=True, name="P")
        if self.fixed_gain:  # scaled gain, columns in output order (linear outputs first)
            self.L_par = cp.Parameter((n, p), name="L", value=np.zeros((n, p)))
            self.Y = self.P @ self.L_par
        else:
            self.L_par = None
            self.Y = cp.Variable((n, p), name="Y")
        self.mu = cp.Variable(q, nonneg=True, name="mu")
        self.Bv = cp.Variable((n, n), symmetric=True, name="B")
        self.t = cp.Variable(name="t")
        self.alpha = cp.Parameter(nonneg=True, name="alpha", value=1.0)
        self.v_par = cp.Parameter(p, nonneg=True, name="vbar", value=np.ones(p))
        self.W_par = cp.Parameter((n, m), name="W", value=np.zeros((n, m))) if m else None
        self.w_ref = cp.Parameter(n, nonneg=True, name="ref", value=np.ones(n))
        self.A_par = [cp.Parameter((n, n), name=f"A{v}") for v in range(self.n_vertices)]
        self.C_par = [cp.Parameter((p, n), name=f"C{v}") for v in range(self.n_vertices)]
        self.vertex_constraints = []
        for A, C in zip(self.A_par, self.C_par):
            B11 = self.P @ A + A.T @ self.P - self.Y @ C - C.T @ self.Y.T + self.alpha * self.P
            B12 = -self.Y @ cp.diag(self.v_par)
            row1 = [B11, B12]
            row2 = [B12.T, -cp.diag(self.mu[:p])]
            rows = [row1, row2]
            if m:
                B13 = self.P @ self.W_par
                row1.append(B13)
                row2.append(np.zeros((p, m)))
                rows.append([B13.T, np.zeros((m, p)), -cp.diag(self.mu[p:])])
            M = cp.bmat(rows)
            self.vertex_constraints.append(0.5 * (M + M.T) << 0)
        cons = list(self.vertex_constraints)
        G = cp.bmat([[self.P, np.eye(n)], [np.eye(n), self.Bv]])
        cons.append(0.5 * (G + G.T) >> 0)
        cons.append(cp.multiply(self.w_ref, cp.diag(self.Bv)) <= self.t)
        if self.multipliers == "per_channel":
            cons.append(cp.sum(self.mu) == self.alpha)
        else:
            cons.append(self.mu == self.alpha * (1.0 / q) * np.ones(q))
        if self.gain_bound is None:
            self.gamma = self.kappa = None
        else:
            dmax = float(self.d.max())
            self.kappa = cp.Variable(nonneg=True, name="kappa")
            self.gamma = cp.Parameter(nonneg=True, name="gamma", value=(self.gain_bound / dmax) ** 2)
            cons.append(self.P >> self.kappa * np.diag((self.d / dmax) ** 2))
            H = cp.bmat([[self.P, self.Y], [self.Y.T, self.gamma * self.kappa * np.eye(p)]])
            cons.append(0.5 * (H + H.T) >> 0)
        self.problem = cp.Problem(cp.Minimize(self.t), cons)

    def set_gain_bound(self, gain_bound: float) -> None:
        """Change the gain bound without rebuilding (only for an LMI built with a bound).

        Parameters
        ----------
        gain_bound : float
            New bound on ``||L||_2`` (positive, finite, model units).
        """
        if self.gamma is None:
            raise ModelError("gain_bound", "a NoiseGainLMI built with gain_bound=...", "one built without")
        self.gain_bound = float(as_positive(gain_bound, "gain_bound", "a positive finite bound"))
        self.gamma.value = (self.gain_bound / float(self.d.max())) ** 2

    # -- solving
    def solve(self, bounds: JacobianBounds, alpha: float, noise: np.ndarray, *, W: np.ndarray | None = None,
              disturbance: np.ndarray | None = None, reference: np.ndarray | None = None,
              noise_scale: float = 1.0, gain: np.ndarray | None = None) -> NoiseBoundDesign:
        """One SDP at decay rate ``alpha``: the smallest worst relative bound, re-checked in numpy.

        Parameters
        ----------
        bounds : JacobianBounds
            The Jacobian box of the region.
        alpha : float
            Decay rate of ``V`` (positive).
        noise : (p,) array
            Output-noise bounds, output order, model units (non-negative).
        W : (n, m) array, optional
            Disturbance input matrix (with ``disturbance``; ``m`` as built).
        disturbance : (m,) array, optional
            Disturbance bounds.
        reference : (n,) array, optional
            Per-state sizes of the objective (default: the box half-widths).
        noise_scale : float, default 1.0
            The SDP is solved for the noise divided by this (the design is linear in the noise:
            ``P`` scales as its inverse square, ``L`` not at all), which keeps ``P`` of order one
            when it is about the size of the relative bound.
        gain : (n, p) array
            The gain analysed (model units, columns in output order); required for an LMI built
            with ``fixed_gain=True``, refused otherwise.

        Returns
        -------
        NoiseBoundDesign
            ``feasible`` only for a solver point that passes the numpy re-check and repair.
        """
        t0 = time.perf_counter()
        system, n = self.system, self.system.n
        alpha = as_positive(alpha, "alpha", "a positive decay rate of V")
        vbar, Wm, wbar, ref = _check_noise(system, noise, W, disturbance, reference, self.m)
        if self.fixed_gain != (gain is not None):
            raise ModelError("gain", "a gain exactly when the LMI was built with fixed_gain=True",
                             "none" if gain is None else "a gain")
        if gain is not None:
            self.L_par.value = _check_gain(gain, system)[:, self.order] / self.d[:, None]
        As, Cs = _scaled_vertices(system, bounds, self.d)
        for par, A in zip(self.A_par, As):
            par.value = A
        for par, C in zip(self.C_par, Cs):
            par.value = C
        r0 = float(noise_scale)
        self.alpha.value = float(alpha)
        self.v_par.value = vbar[self.order] / r0
        W_bar = (Wm * wbar[None, :]) / self.d[:, None] if self.m else np.zeros((n, 0))
        if self.m:
            self.W_par.value = W_bar / r0
        self.w_ref.value = (self.d / ref) ** 2
        base = dict(reference=ref, noise=vbar, disturbance=wbar, W=Wm, gain_bound=self.gain_bound,
                    multipliers=self.multipliers, alpha_solved=float(alpha), scaling=self.d, system=system,
                    bounds=bounds)

        def read(status) -> NoiseBoundDesign:
            return self._read_point(status, As, Cs, float(alpha), vbar[self.order], W_bar, r0, base, t0)

        out = solve_problem(self.problem, accept=lambda: read(Status.OPTIMAL).feasible)
        if out.status in POINT_STATUSES and self.P.value is not None:
            return read(out.status)
        return NoiseBoundDesign(False, out.status, None, None, float("nan"), None, float("nan"), None,
                                gain_norm=None, seconds=time.perf_counter() - t0, **base)

    def _read_point(self, status, As, Cs, alpha, v_ord, W_bar, r0, base, t0) -> NoiseBoundDesign:
        """The solver's current point, repaired and re-checked in numpy."""
        nan = float("nan")

        def failed(**kw):
            kw.setdefault("gain_norm", None)
            return NoiseBoundDesign(False, Status.RECHECK_FAILED, None, None, nan, None, nan, None,
                                    seconds=time.perf_counter() - t0, **base, **kw)

        vals = [self.P.value, self.Y.value, self.mu.value]
        if any(v is None for v in vals) or not all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in vals):
            return failed()
        Pt = 0.5 * (np.asarray(self.P.value, dtype=float) + np.asarray(self.P.value, dtype=float).T)
        w = np.linalg.eigvalsh(Pt)
        if not w[0] > 0.0:
            return failed(p_min_eig=float(w[0]))
        # a fixed gain is delivered as given (the re-check below is of that gain)
        L_bar = (np.array(self.L_par.value, dtype=float) if self.fixed_gain
                 else np.linalg.solve(Pt, np.asarray(self.Y.value, dtype=float)))
        mu = np.clip(np.asarray(self.mu.value, dtype=float), 0.0, None)
        P_bar = Pt / r0 ** 2  # the LMI was solved for the noise / r0
        alpha2, mu2, blocks = _repair(P_bar, L_bar, alpha, mu, As, Cs, v_ord, W_bar)
        eigs = tuple(float(np.linalg.eigvalsh(B)[-1]) for B in blocks)
        level = float(np.sum(mu2)) / alpha2 if alpha2 > 0 else nan
        level0 = float(np.sum(mu)) / alpha
        if not (alpha2 >= alpha * (1.0 - NOISE_LMI_REPAIR_RTOL) and level <= level0 * (1.0 + NOISE_LMI_REPAIR_RTOL)
                and max(eigs) <= 0.0 and level0 > 0):
            return failed(lmi_max_eig=eigs, p_min_eig=float(w[0] / r0 ** 2))
        n, p = self.system.n, self.system.p
        L = np.zeros((n, p))
        L[:, self.order] = self.d[:, None] * L_bar
        gain = float(np.linalg.norm(L, 2))
        if self.gain_bound is not None and gain > self.gain_bound * (1 + GAIN_BOUND_RTOL):
            return failed(lmi_max_eig=eigs, p_min_eig=float(w[0] / r0 ** 2), gain_norm=gain)
        bound = _bounds_from(P_bar, self.d, level)
        P = P_bar / self.d[:, None] / self.d[None, :]
        return NoiseBoundDesign(True, status, L, P, float(alpha2), mu2, level, bound, gain_norm=gain,
                                lmi_max_eig=eigs, p_min_eig=float(w[0] / r0 ** 2),
                                seconds=time.perf_counter() - t0, **base)


def _check_gain(gain, system) -> np.ndarray:
    """A gain to analyse: a finite ``(n, p)`` array (model units, columns in output order)."""
    L = np.asarray(gain, dtype=float)
    if L.shape != (system.n, system.p) or not np.all(np.isfinite(L)):
        raise ModelError("gain", f"a finite ({system.n}, {system.p}) observer gain", f"shape {np.shape(gain)}")
    return L


def _check_noise(system, noise, W, disturbance, reference, m_expected: int | None = None):
    """Validated ``(vbar, W, wbar, reference)`` (model units)."""
    n, p = system.n, system.p
    vbar = np.asarray(noise, dtype=float).reshape(-1)
    if vbar.shape != (p,) or not np.all(np.isfinite(vbar) & (vbar >= 0)):
        raise ModelError("noise", f"{p} non-negative finite bounds on the output noise (one per output)", repr(noise))
    if (W is None) != (disturbance is None):
        raise ModelError("disturbance", "both W and the disturbance bounds, or neither", "only one of them")
    if W is None:
        Wm, wbar = np.zeros((n, 0)), np.zeros(0)
    else:
        Wm = np.asarray(W, dtype=float)
        if Wm.ndim == 1:
            Wm = Wm.reshape(n, 1)
        wbar = np.asarray(disturbance, dtype=float).reshape(-1)
        if Wm.shape != (n, wbar.size) or not np.all(np.isfinite(Wm)) or not np.all(np.isfinite(wbar) & (wbar >= 0)):
            raise ModelError("W, disturbance", f"an (n, m) = ({n}, m) matrix and m non-negative bounds",
                             f"shapes {np.shape(W)} and {np.shape(disturbance)}")
    if m_expected is not None and wbar.size != m_expected:
        raise ModelError("disturbance", f"{m_expected} channels (as the LMI was built)", f"{wbar.size}")
    if not (np.any(vbar > 0) or np.any(wbar * np.abs(Wm).sum(axis=0) > 0)):
        raise ModelError("noise", "some positive noise or disturbance bound", "all zero")
    ref = 0.5 * (system.box_upper - system.box_lower) if reference is None else np.asarray(reference, dtype=float)
    ref = np.where(ref > 0, ref, 1.0) if reference is None else ref
    if ref.shape != (n,) or not np.all(np.isfinite(ref) & (ref > 0)):
        raise ModelError("reference", f"{n} positive per-state sizes", repr(reference))
    return vbar, Wm, wbar, ref


# ---------------------------------------------------------------------------- searches over alpha
def _polytopic_rate(system, bounds, gain_bound, d, sigma_cap):
    """Largest decay rate of the polytopic condition (the end of the noise LMI's range of ``alpha``)."""
    from .polytopic import PolytopicLMI

    lmi = PolytopicLMI.compiled(system, gain_bound=gain_bound, scaling=d)
    return lmi, lmi.max_decay(bounds, sigma_cap)


def _no_rate_error(system, bounds, lmi, rate: float, gain_bound):
    """The error for a decay rate ``rate`` no gain reaches, or ``None`` when the polytopic condition holds there.

    The polytopic condition (:mod:`.polytopic`) is solved, and certified, at ``rate (1 -``
    :data:`~hybobs_opt.tolerances.NOISE_RATE_CERTIFICATE_RTOL` ``)``: strict infeasibility there
    excludes a non-strict solution of the noise LMI at every ``alpha >= rate`` (its blocks contain
    the polytopic ones, and non-strict at ``alpha`` is strict at any lower rate).  The polytopic
    certificate speaks for every gain; under a gain bound, when it does not verify, the Farkas ray
    of the bounded problem speaks for the problem as posed (the bound's sufficient LMI form and
    :data:`~hybobs_opt.tolerances.LMI_STRICT_MARGIN`).  Without either: a :class:`SolverError`.
    """
    from ..tolerances import NOISE_RATE_CERTIFICATE_RTOL
    from .farkas import verified_farkas

    r_cert = rate * (1.0 - NOISE_RATE_CERTIFICATE_RTOL)
    sol = lmi.solve(bounds, r_cert)
    if sol.feasible:
        return None
    reg = bounds.region
    where = "the whole operating box" if reg is None else f"{reg.name} in [{reg.lo:.6g}, {reg.hi:.6g}]"
    bound_text = "" if gain_bound is None else f" with ||L||_2 <= {gain_bound:g}"
    what = f"noise-gain design of {system.name} on {where} at decay rate {rate:g}{bound_text}"
    need = "any positive decay rate" if rate == 0.0 else f"a decay rate of {rate:g} or more"
    cert = lmi.certify(sol)
    if cert is not None:
        return InfeasibleError(what, cert, f"no gain gives V = e'Pe {need} on every vertex of the Jacobian box (the "
                               f"polytopic condition, which the noise LMI implies, is infeasible at {r_cert:.6g}; "
                               "certificate re-checked in numpy)")
    cert = verified_farkas(lmi, f"the polytopic condition at decay rate {r_cert:.6g}{bound_text}")
    if cert is not None:
        return InfeasibleError(what, cert, f"the polytopic condition at decay rate {r_cert:.6g}{bound_text}, which a "
                               f"noise design at {need} satisfies up to the condition's strict margin, is infeasible "
                               "as posed (the bound in its sufficient LMI form; Farkas certificate re-checked in numpy)")
    return SolverError(what, SOLVER, str(sol.status), "no point was confirmed and no certificate of infeasibility "
                       "verified; lower the required decay rate, raise the gain bound or rescale the model")


def noise_optimal_design(system: ScalarNonlinearSystem, bounds: JacobianBounds, noise, *, W=None, disturbance=None,
                         gain_bound: float | None = None, min_decay: float | None = None,
                         alpha: float | None = None, scaling: np.ndarray | None = None, reference=None,
                         multipliers: str = "per_channel", sigma_cap: float | None = None,
                         grid: int | None = None, rtol: float | None = None, gain=None) -> NoiseBoundDesign:
    """The gain with the smallest certified ultimate error bound under bounded noise (module docstring).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004 (without ``g(y, u)``).
    bounds : JacobianBounds
        The Jacobian box of the region (:func:`.bounds.jacobian_bounds`); the bound holds while the
        state and the estimate stay in that region.
    noise : (p,) array
        Output-noise bounds ``|v_j| <= noise[j]`` (output order, model units).
    W : (n, m) array, optional
        How a process disturbance enters (``x' = ... + W w``), with ``disturbance``.
    disturbance : (m,) array, optional
        Disturbance bounds ``|w_i| <= disturbance[i]``.
    gain_bound : float, optional
        ``||L||_2 <= gain_bound`` (sufficient LMI form, model units).
    min_decay : float, optional
        Required decay rate of ``V`` without noise: only ``alpha >= min_decay`` is searched.
    alpha : float, optional
        Solve at this one rate instead of searching.
    scaling : (n,) array, optional
        State scaling of the LMI (default: the box half-widths).
    reference : (n,) array, optional
        Per-state sizes the bound is minimised against (default: the box half-widths).
    multipliers : {"per_channel", "pooled"}
        See the module docstring.
    sigma_cap : float, optional
        Upper end of the polytopic decay-rate search (default :data:`~hybobs_opt.defaults.SIGMA_CAP`).
    grid : int, optional
        Rates of the first, geometric, grid (default :data:`~hybobs_opt.defaults.NOISE_ALPHA_GRID`).
    rtol : float, optional
        Relative width in ``alpha`` at which the golden-section refinement stops (default
        :data:`~hybobs_opt.defaults.NOISE_ALPHA_RTOL`).
    gain : (n, p) array, optional
        Analyse this gain (model units, output order) instead of designing one: the same search
        over ``alpha`` with ``Y = P L`` fixed, up to the largest rate a Lyapunov matrix proves for
        the gain (:func:`.gain_search.gain_decay_rate`).  No gain bound with it.

    Returns
    -------
    NoiseBoundDesign
        The best checked design over the rates tried (its ``search`` lists them).

    Raises
    ------
    InfeasibleError
        No gain reaches ``min_decay`` (or any positive rate): the polytopic condition's certificate,
        re-checked in numpy (under a gain bound, possibly the Farkas ray of the bounded condition as
        posed; see :func:`_no_rate_error`).
    SolverError
        No rate gave a checked design and no certificate was verified.

    See Also
    --------
    NoiseBoundDesign : What it returns.
    noise_tradeoff : The bound against the decay rate.
    decay_optimal_design : The fastest gain instead.

    Examples
    --------
    The pendulum's angle is measured to 0.01 rad; the gain below keeps the error within the printed
    bounds (rad, rad/s) once the transient is over:

    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import noise_optimal_design
    >>> design = noise_optimal_design(pendulum, bounds, [0.01], gain_bound=10.0, alpha=0.5)
    >>> np.round(design.bound, 4), design.verify()
    (array([0.0174, 0.0174]), True)
    """
    from dataclasses import replace

    from ..defaults import NOISE_ALPHA_GRID, NOISE_ALPHA_MIN_FRACTION, NOISE_ALPHA_RTOL, SIGMA_CAP

    t0 = time.perf_counter()
    gain_bound = as_positive(gain_bound, "gain_bound", "a positive finite bound on ||L||_2", allow_none=True)
    min_decay = as_positive(min_decay, "min_decay", "a positive decay rate", allow_none=True)
    vbar, Wm, wbar, ref = _check_noise(system, noise, W, disturbance, reference)
    if gain is not None:
        if gain_bound is not None:
            raise ModelError("gain_bound", "no gain bound when a gain is given to analyse", repr(gain_bound))
        gain = _check_gain(gain, system)
    build = dict(n_disturbance=wbar.size, scaling=scaling, multipliers=multipliers, fixed_gain=gain is not None)
    lmi = NoiseGainLMI.compiled(system, gain_bound=gain_bound, **build)
    kw = dict(W=Wm if wbar.size else None, disturbance=wbar if wbar.size else None, reference=ref)
    if gain is not None:
        kw["gain"] = gain
    log: list[tuple[float, float, str]] = []
    state = {"scale": None, "best": None}
    tol = math.log(1.0 + (NOISE_ALPHA_RTOL if rtol is None else rtol))

    def run(a: float) -> NoiseBoundDesign:
        scale = state["scale"]
        if scale is None:  # a probe solve sets the noise scale that keeps the SDP of order one
            probe = lmi.solve(bounds, a, vbar, noise_scale=1.0, **kw)
            scale = state["scale"] = _noise_scale(probe)
        des = lmi.solve(bounds, a, vbar, noise_scale=scale, **kw)
        if des.feasible and gain_bound is not None:
            if des.gain_norm > gain_bound * (1 + GAIN_BOUND_RTOL):  # only under a raised internal bound
                log.append((float(a), float("nan"), f"||L||_2 = {des.gain_norm:.4g} above the gain bound"))
                return replace(des, feasible=False)
            des = replace(des, gain_bound=gain_bound, internal_gain_bound=lmi.gain_bound)
        log.append((float(a), des.worst_relative if des.feasible else float("nan"), str(des.status)))
        if des.feasible:
            state["scale"] = _noise_scale(des)
            best = state["best"]
            if best is None or des.worst_relative < best.worst_relative:
                state["best"] = des
        return des

    def value(a: float) -> float:
        des = run(a)
        return des.worst_relative if des.feasible else float("inf")

    if alpha is not None:
        alpha = as_positive(alpha, "alpha", "a positive decay rate of V")
        if min_decay is not None and alpha < min_decay:
            raise ModelError("alpha", f"a rate >= min_decay = {min_decay:g}", f"{alpha:g}")
        run(alpha)
        lo = hi = alpha
    else:
        if gain is not None:
            from .gain_search import gain_decay_rate

            hi = gain_decay_rate(system, bounds, gain, scaling=lmi.d)[0]
            if not hi > 0.0:
                raise ModelError("gain", "a gain whose error dynamics one quadratic Lyapunov function proves stable "
                                 "on every vertex of the Jacobian box", f"best proven rate {hi:.4g}")
            if min_decay is not None and min_decay > hi:
                raise ModelError("min_decay", f"at most {hi:.6g}, the largest rate proven for the gain",
                                 f"{min_decay:g}")
        else:
            plmi, decay = _polytopic_rate(system, bounds, gain_bound, lmi.d,
                                          SIGMA_CAP if sigma_cap is None else sigma_cap)
            hi = float(decay.sigma_max)
            if min_decay is not None and min_decay > hi:
                err = _no_rate_error(system, bounds, plmi, float(min_decay), gain_bound)
                if err is not None:
                    raise err
                hi = float(min_decay)
            if hi <= 0.0:
                raise _no_rate_error(system, bounds, plmi, 0.0, gain_bound) or SolverError(
                    f"noise-gain design of {system.name}", SOLVER, "no positive decay rate",
                    "raise the gain bound or shrink the region")
        lo = max(min_decay or 0.0, hi * NOISE_ALPHA_MIN_FRACTION)
        k = NOISE_ALPHA_GRID if grid is None else max(int(grid), 2)
        alphas = np.geomspace(lo, hi, k) if hi > lo else np.array([lo])
        vals = [value(a) for a in alphas]
        i = int(np.argmin(vals))
        if np.isfinite(vals[i]) and alphas.size > 1:
            _golden(value, math.log(alphas[max(i - 1, 0)]), math.log(alphas[min(i + 1, alphas.size - 1)]), tol)
    if gain_bound is not None and state["best"] is not None:
        _tighten(state, lmi, run, value, gain_bound, lo, hi, tol, alpha is None)
        lmi.set_gain_bound(gain_bound)  # the compiled problem back at the user's bound
    best = state["best"]
    if best is None:
        last = log[-1][2] if log else "no solve"
        raise SolverError(f"noise-gain design of {system.name}", SOLVER, last,
                          "no rate gave a point that passed the numpy re-check; rescale the model (scaling=...), "
                          "set a gain bound, or give a decay rate (alpha=...)")
    return replace(best, seconds=time.perf_counter() - t0, search=tuple(log))


def _tighten(state, lmi, run, value, gain_bound: float, lo: float, hi: float, tol: float, search: bool) -> None:
    """Raise the LMI's internal gain bound while the gain's own norm stays within the user's.

    The LMI bounds ``||L||_2`` sufficiently (``P >= kappa I`` and a Schur complement), and the
    noise design is shaped by that constraint: for the pendulum measured by ``cos(theta)`` on
    ``[0.2, pi/2]`` with noise 0.01 and ``||L||_2 <= 20``, the internal bound 20 gives a gain of norm
    10.3 and a bound of 1.17 rad on ``theta``, the internal bound 40 a gain of norm 20.0 and 0.30 rad.  As in
    :func:`.decay_design._tighten`, the internal bound is scaled by ``gain_bound / ||L||`` while the
    returned gain stays within the user's bound and bisected (geometric mean) once it does not, at
    the best rate found (at most :data:`~hybobs_opt.defaults.GAIN_BOUND_TIGHTENING_STEPS` solves);
    the rate is then refined again with the last internal bound that kept the gain within the
    user's.  Only designs whose gain is within the user's bound are kept (``run`` drops the others).
    """
    from ..defaults import GAIN_BOUND_TIGHT_FRACTION, GAIN_BOUND_TIGHTENING_STEPS

    best = state["best"]
    a_best = best.alpha_solved
    ok_bound, bad_bound = gain_bound, None
    norm = best.gain_norm
    for _ in range(GAIN_BOUND_TIGHTENING_STEPS):
        if norm >= GAIN_BOUND_TIGHT_FRACTION * gain_bound:
            break
        trial = ok_bound * gain_bound / max(norm, 1e-12 * gain_bound) if bad_bound is None else math.sqrt(
            ok_bound * bad_bound)
        lmi.set_gain_bound(trial)
        des = run(a_best)
        if not des.feasible:
            if des.gain_norm is not None and des.gain_norm > gain_bound:
                bad_bound = trial
                continue
            break
        ok_bound, norm = trial, des.gain_norm
    if ok_bound > gain_bound and search:
        lmi.set_gain_bound(ok_bound)
        a_best = state["best"].alpha_solved
        a, b = max(lo, a_best / 2.0), min(hi, a_best * 2.0)
        if b > a:
            _golden(value, math.log(a), math.log(b), tol)


def _noise_scale(des: NoiseBoundDesign) -> float:
    """The noise divisor for the next solve: the worst relative bound of ``des`` (1 without a point).

    The SDP's objective ``t`` is then about one and ``P`` about one in its tightest direction;
    Clarabel stops far from the optimum (with status ``optimal``) when ``t`` is of order 1e-2 and ``P``
    of order 1e3 (the robot at ``alpha = 2``: 25 % above the bound found at any scale in
    ``[1e-2, 0.3]``).
    """
    if not des.feasible:
        return 1.0
    return float(des.worst_relative)


def _golden(f, a: float, b: float, tol: float) -> None:
    """Golden-section search of ``f(exp(x))`` on ``[a, b]`` until the bracket is narrower than ``tol``."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(math.exp(c)), f(math.exp(d))
    while b - a > tol:
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(math.exp(c))
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(math.exp(d))


def noise_tradeoff(system: ScalarNonlinearSystem, bounds: JacobianBounds, noise, alphas, *, W=None,
                   disturbance=None, gain_bound: float | None = None, scaling: np.ndarray | None = None,
                   reference=None, multipliers: str = "per_channel") -> NoiseTradeoff:
    """The smallest certified bound at each decay rate of ``alphas`` (the rate/noise trade-off curve).

    Each rate is one SDP (:meth:`NoiseGainLMI.solve`), its point re-checked in numpy; a rate with
    no checked point (beyond the largest decay rate of the polytopic condition, or undecided) gives
    ``nan``.

    Parameters
    ----------
    system, bounds, noise, W, disturbance, gain_bound, scaling, reference, multipliers
        As for :func:`noise_optimal_design`.
    alphas : sequence of float
        Positive decay rates of ``V``.

    Returns
    -------
    NoiseTradeoff
        Arrays over ``alphas``.

    See Also
    --------
    NoiseTradeoff : What it returns.
    noise_optimal_design : One design with the rate chosen.
    plot_noise_tradeoff : Draws the curve.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import noise_tradeoff
    >>> curve = noise_tradeoff(pendulum, bounds, [0.01], [0.1, 0.5, 1.0], gain_bound=10.0)
    >>> curve.bound.shape, bool(curve.feasible.all())
    ((3, 2), True)
    """
    gain_bound = as_positive(gain_bound, "gain_bound", "a positive finite bound on ||L||_2", allow_none=True)
    a = np.asarray(alphas, dtype=float).reshape(-1)
    if a.size == 0 or not np.all(np.isfinite(a) & (a > 0)):
        raise ModelError("alphas", "positive finite decay rates", repr(alphas))
    vbar, Wm, wbar, ref = _check_noise(system, noise, W, disturbance, reference)
    lmi = NoiseGainLMI.compiled(system, n_disturbance=wbar.size, gain_bound=gain_bound, scaling=scaling,
                                multipliers=multipliers)
    kw = dict(W=Wm if wbar.size else None, disturbance=wbar if wbar.size else None, reference=ref)
    n = system.n
    designs, scale = [], None
    for alpha in a:
        if scale is None:
            scale = _noise_scale(lmi.solve(bounds, alpha, vbar, noise_scale=1.0, **kw))
        des = lmi.solve(bounds, alpha, vbar, noise_scale=scale, **kw)
        if des.feasible:
            scale = _noise_scale(des)
        designs.append(des)
    ok = np.array([d.feasible for d in designs], dtype=bool)
    nan = float("nan")
    return NoiseTradeoff(
        a, np.array([d.alpha if d.feasible else nan for d in designs]),
        np.array([d.worst_relative if d.feasible else nan for d in designs]),
        np.array([d.bound if d.feasible else np.full(n, nan) for d in designs]).reshape(a.size, n),
        np.array([d.gain_norm if d.feasible else nan for d in designs]), ok, tuple(designs))
