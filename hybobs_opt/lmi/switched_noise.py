"""A certified ultimate error bound for a switched-gain observer under bounded noise, with its dwell time.

Each region ``i`` of a switched design (:mod:`.switched`, paper 004 Section 5) keeps its gain
``L_i``; :func:`.noise_gain.noise_optimal_design` with ``gain=L_i`` gives an invariant ellipsoid
of the region under the stated noise: ``U_i = e' P_i e / c_i`` (``c_i`` the ellipsoid's level)
obeys ``U_i' <= -alpha_i (U_i - 1)`` while the plant state and the estimate stay in the region.
At a switch from ``i`` to ``j``, ``U_j <= mu_ij U_i`` with
``mu_ij = lambda_max((P_i / c_i)^-1/2 (P_j / c_j) (P_i / c_i)^-1/2)``.

With ``alpha = min_i alpha_i``, ``mu = max`` over the switches the design allows, and switches at
least ``tau`` apart, the value ``u_k`` of ``U`` just after the ``k``-th switch obeys
``u_{k+1} <= mu (1 + (u_k - 1) e^{-alpha tau})`` while ``u_k >= 1`` (and stays below ``mu`` once
``u_k <= 1``), so for ``q = mu e^{-alpha tau} < 1`` it converges geometrically (ratio ``q``) into

.. math::

    u^* = \\max\\Big(1,\\ \\frac{\\mu (1 - e^{-\\alpha\\tau})}{1 - \\mu e^{-\\alpha\\tau}}\\Big),

and between switches ``U`` only decreases towards 1.  Ultimately ``e' P_i e <= u* c_i`` in
whichever region is active, hence ``|e_k| <= sqrt(u*) max_i sqrt(c_i (P_i^-1)_kk)``: the
per-region bounds inflated by ``sqrt(u*)``.  The bound needs ``tau > ln(mu) / alpha`` (the dwell
time needed); the dwell time assumed is the one the design's hysteresis guarantees at its maximum
rate of the scheduling variable, else the design's ``tau`` (eqs. 47-48), stated as an assumption.
This is the dwell-time argument of eqs. (47)-(48) (paper 004; D. Liberzon, *Switching in Systems
and Control*, Birkhauser 2003, Sec. 3.2.1) applied to the invariant ellipsoids instead of the
decay certificates.

Ellipsoids chosen region by region can differ so much in shape that ``mu`` needs a dwell time no
hysteresis gives (the vehicle tracker: ``mu = 7.5``, 1.4 s needed, 0.53 s guaranteed).  So the
ellipsoids are also designed *jointly*: one SDP over all ``P_i`` and multipliers at a common rate
``alpha``, with ``P_j <= m P_i`` for every switch (levels are 1: ``sum_j mu_j = alpha``), which
bounds the jump by ``m``; ``(alpha, m)`` run over a grid with ``m < e^{alpha tau}``.  The
candidate kept is the one whose final bound (recomputed in numpy from the re-checked ``P_i``,
levels and rates, never from ``m``) has the smallest worst ratio to the reference sizes.  Every
certificate bounds every state, so each state's bound is then tightened by a certificate whose
``P_i`` minimise that state's bound alone (the same gains and rate; :class:`StateCertificate`).

With ``design_gains=True`` the gains are unknowns too (``Y_i = P_i L_i``, the bound on ``||L_i||``
in the sufficient form of :mod:`.noise_gain`, ``alpha`` at least a required rate): the same
search then designs gains for the noise on the design's regions instead of bounding its own.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from ..errors import ModelError
from ..status import Status
from ..tolerances import GAIN_BOUND_RTOL
from .noise_gain import (NoiseBoundDesign, _bounds_from, _check_noise, _output_order, _repair, _scaled_vertices,
                         noise_optimal_design)
from .solve import POINT_STATUSES, solve_problem
from .switched import SwitchedDesign

__all__ = ["StateCertificate", "SwitchedNoiseBound", "switched_noise_bound"]


@dataclass(frozen=True)
class StateCertificate:
    """A certificate of the switched bound chosen for one state (its ``P_i`` minimise that state's bound).

    Parameters
    ----------
    state : int
        The state it was chosen for.
    by_region : tuple of NoiseBoundDesign
        The regions' re-checked ellipsoids.
    jumps, alpha, jump, dwell_needed, level, bound
        As for :class:`SwitchedNoiseBound`, of this certificate (``bound`` covers every state).

    See Also
    --------
    switched_noise_bound : Adds one per state it tightens.
    SwitchedNoiseBound : Holds them in ``state_certificates``.

    Examples
    --------
    One state's certificate exists only where it beats the common one; a one-state plant has none:

    >>> import numpy as np
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A scalar plant ``x' = -sin(x) + u``, ``y = x``, with one gain for ``x < 0`` and one for ``x > 0``:

    >>> import casadi as ca

    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> plant = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), A=[[0.0]], C=[[1.0]],
    ...                               F=[[-1.0]], E=[[1.0]], f=(sine,), B=[[1.0]], name="scalar")
    >>> regions = regions_from_switch_points(plant, "x", -1.0, 1.0, [0.0], 0.1)
    >>> design = synthesize_switched(plant, regions, gain_bound=10.0, max_rate=2.0, overlap=0.1)
    >>> from hybobs_opt.lmi import switched_noise_bound
    >>> snb = switched_noise_bound(design, [0.01])
    >>> snb.state_certificates
    ()
    >>> [(c.state, c.bound[c.state] <= snb.bound[c.state]) for c in snb.state_certificates]
    []
    """

    state: int
    by_region: tuple = field(repr=False)
    jumps: dict = field(repr=False)
    alpha: float
    jump: float
    dwell_needed: float
    level: float
    bound: np.ndarray

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"state": self.state, "alpha": self.alpha, "jump": self.jump, "dwell_needed": self.dwell_needed,
                "level": self.level, "bound": self.bound.tolist()}


@dataclass(frozen=True)
class SwitchedNoiseBound:
    """The certified ultimate bound of a switched-gain observer under bounded noise (see the module).

    Parameters
    ----------
    design : SwitchedDesign
        The switched design analysed (its gains unchanged).
    by_region : tuple of NoiseBoundDesign
        Each region's invariant ellipsoid for its own gain (``alpha``, ``level``, ``bound``).
    jumps : dict
        ``(i, j) -> mu_ij``: the factor of the normalised Lyapunov value at a switch from ``i`` to ``j``.
    alpha : float
        ``min_i alpha_i``.
    jump : float
        ``max mu_ij`` over the switches (1 without switches).
    dwell : float
        The dwell time assumed: consecutive switches at least this far apart.
    dwell_source : str
        Where it comes from (the hysteresis at the maximum rate, or the design's ``tau``).
    dwell_needed : float
        ``ln(jump) / alpha``: the bound needs ``dwell`` above it.
    level : float or None
        ``u*`` (``None`` when ``dwell <= dwell_needed``: no bound).
    bound : (n,) array or None
        Per-state ultimate bound in the model's units (``None`` without one).
    noise : (p,) array
        The output-noise bounds, output order.
    seconds : float
    method : str
        ``"per region"`` (each ellipsoid on its own) or ``"joint"`` (one SDP with the switches coupled).
    candidates : tuple of dict
        Every candidate tried (``alpha``, ``m``, the jump, the dwell needed and the worst relative bound).
    gains : str
        ``"given"`` (the design's gains, bounded) or ``"designed"`` (new gains minimising the bound,
        in ``by_region[i].L``).
    state_certificates : tuple of StateCertificate
        Certificates that each bound one state tighter than ``by_region`` does (same gains, same
        rate, ``P_i`` chosen for that state); ``bound[k]`` is the smallest bound any certificate gives.

    See Also
    --------
    switched_noise_bound : Returns one.
    check_switched_noise_bound : Compares it with simulations.
    NoiseBoundDesign : The bound of one region.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A scalar plant ``x' = -sin(x) + u``, ``y = x``, with one gain for ``x < 0`` and one for ``x > 0``:

    >>> import casadi as ca

    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> plant = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), A=[[0.0]], C=[[1.0]],
    ...                               F=[[-1.0]], E=[[1.0]], f=(sine,), B=[[1.0]], name="scalar")
    >>> regions = regions_from_switch_points(plant, "x", -1.0, 1.0, [0.0], 0.1)
    >>> design = synthesize_switched(plant, regions, gain_bound=10.0, max_rate=2.0, overlap=0.1)
    >>> from hybobs_opt.lmi import switched_noise_bound
    >>> snb = switched_noise_bound(design, [0.01])
    >>> snb.holds, np.round(snb.bound, 4)
    (True, array([0.009]))
    >>> bool(snb.dwell > snb.dwell_needed), len(snb.by_region)
    (True, 2)
    >>> print(snb.claim())  # doctest: +ELLIPSIS
    Under output noise |v| <= [0.01] the switched observer's error ends in |e_x| <= ...
    """

    design: SwitchedDesign = field(repr=False)
    by_region: tuple[NoiseBoundDesign, ...] = field(repr=False)
    jumps: dict
    alpha: float
    jump: float
    dwell: float
    dwell_source: str
    dwell_needed: float
    level: float | None
    bound: np.ndarray | None
    noise: np.ndarray
    seconds: float
    method: str = "per region"
    candidates: tuple = ()
    gains: str = "given"
    state_certificates: tuple = ()

    @property
    def holds(self) -> bool:
        """The dwell time assumed exceeds the one needed: the bound is certified."""
        return self.bound is not None

    @property
    def peak_to_peak_gain(self) -> np.ndarray | None:
        """Per state, the bound per unit of the largest output-noise bound (the bound is linear in the noise)."""
        top = float(np.max(self.noise)) if self.noise.size else 0.0
        return None if self.bound is None or top <= 0 else self.bound / top

    @property
    def wider_than_regions(self) -> bool:
        """The bound on the scheduling coordinate exceeds the narrowest region: the condition that the state
        stays in the active region is then not made plausible by the bound itself."""
        if self.bound is None:
            return False
        k = self.design.coordinate
        return bool(self.bound[k] > min(r.region.hi - r.region.lo for r in self.design.regions))

    def scaled(self, factor: float) -> "SwitchedNoiseBound":
        """The certified bound of the same switched observer for the output noise ``factor * noise``.

        The certificate is homogeneous in the noise: each region's vertex blocks
        ``[[He(P A_cl) + alpha P, -P L diag(vbar)], [., -diag(mu)]]`` at ``(P / s^2, s vbar)`` are the
        blocks at ``(P, vbar)`` under the congruence ``diag(I / s, I)``, so they stay negative
        semidefinite with the same ``alpha``, ``mu`` and level ``c = sum(mu) / alpha``; every ``P_i``
        scales alike, so the jumps ``mu_ij``, the dwell time needed and ``u*`` are unchanged and the
        bound scales by ``s``.  The returned designs are re-checked by their ``verify()`` like any other.

        Parameters
        ----------
        factor : float
            ``s > 0``.

        Returns
        -------
        SwitchedNoiseBound
            With ``P_i / s^2``, noise and bounds times ``s``; ``candidates`` dropped (they describe the search).
        """
        from dataclasses import replace

        s = float(factor)
        if not (math.isfinite(s) and s > 0):
            raise ModelError("factor", "a positive finite noise factor", repr(factor))

        def region(d):
            d2 = replace(d, P=d.P / s ** 2, noise=d.noise * s, bound=None if d.bound is None else d.bound * s)
            chk = d2.check()
            return replace(d2, lmi_max_eig=chk.vertex_max_eig, p_min_eig=chk.p_min_eig)

        states = tuple(replace(c, by_region=tuple(region(d) for d in c.by_region), bound=c.bound * s)
                       for c in self.state_certificates)
        return replace(self, by_region=tuple(region(d) for d in self.by_region),
                       bound=None if self.bound is None else self.bound * s, noise=self.noise * s, candidates=(),
                       state_certificates=states)

    def claim(self) -> str:
        """What is proven, in one sentence.

        Returns
        -------
        str
            What is proven, in one sentence.
        """
        names = self.design.system.state_names
        noise = np.round(self.noise, 6).tolist()
        if not self.holds:
            return (f"No switched noise bound: the invariant ellipsoids of the regions grow by up to {self.jump:.4g} "
                    f"at a switch and shrink at rate {self.alpha:.4g} 1/s, so switches must be more than "
                    f"{self.dwell_needed:.4g} s apart; the dwell time assumed ({self.dwell_source}) is {self.dwell:.4g} s.")
        bound = ", ".join(f"|e_{nm}| <= {b:.4g}" for nm, b in zip(names, self.bound))
        whose = "its gain" if self.gains == "given" else "the gain designed for it"
        return (f"Under output noise |v| <= {noise} the switched observer's error ends in {bound} (each region's "
                f"invariant ellipsoid for {whose}, re-checked in numpy, inflated by sqrt(u*) = {math.sqrt(self.level):.4g} "
                f"for switches at least {self.dwell:.4g} s apart ({self.dwell_source}; {self.dwell_needed:.4g} s "
                "needed), while the state and the estimate stay in the active region)."
                + ("" if not self.state_certificates else
                   " The bounds on " + ", ".join(names[c.state] for c in self.state_certificates)
                   + " come from certificates chosen for those states (same gains and rate).")
                + (f" The bound on {names[self.design.coordinate]} is wider than a region, so it does not keep the "
                   "state in the active region by itself." if self.wider_than_regions else ""))

    def to_dict(self, unit: str = "", factor: float = 1.0) -> dict:
        """JSON-ready fields; region intervals in the display unit (model value / ``factor``).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        def arr(a):
            return None if a is None else np.asarray(a).tolist()

        return {"holds": self.holds, "bound": arr(self.bound), "wider_than_regions": self.wider_than_regions, "peak_to_peak_gain": arr(self.peak_to_peak_gain),
                "noise": arr(self.noise), "alpha": self.alpha, "jump": self.jump, "dwell": self.dwell,
                "dwell_source": self.dwell_source, "dwell_needed": self.dwell_needed, "level": self.level,
                "method": self.method, "gains": self.gains, "claim": self.claim(), "candidates": list(self.candidates),
                "state_certificates": [c.to_dict() for c in self.state_certificates],
                "jumps": [{"from": i, "to": j, "mu": mu} for (i, j), mu in sorted(self.jumps.items())],
                "unit": unit,
                "regions": [{"interval": [r.region.lo / factor, r.region.hi / factor], "sigma": r.sigma,
                             "sigma_verified": r.sigma_verified, "alpha": d.alpha, "level": d.level,
                             "bound": arr(d.bound), "gain_norm": d.gain_norm, "verified": bool(d.verify()),
                             **({"L": arr(d.L)} if self.gains == "designed" else {})}
                            for r, d in zip(self.design.regions, self.by_region)],
                "seconds": self.seconds}


def _jump(Pi: np.ndarray, ci: float, Pj: np.ndarray, cj: float) -> float:
    """``max_e (e' P_j e / c_j) / (e' P_i e / c_i)``."""
    A = 0.5 * (Pi + Pi.T) / ci
    w, U = np.linalg.eigh(A)
    if not w[0] > 0:
        raise ModelError("P", "positive definite Lyapunov matrices", f"smallest eigenvalue {w[0]:.3g}")
    R = U @ np.diag(w ** -0.5) @ U.T
    M = R @ (0.5 * (Pj + Pj.T) / cj) @ R
    return float(np.linalg.eigvalsh(0.5 * (M + M.T))[-1])


class _JointNoiseLMI:
    """The noise blocks of every region, coupled by ``P_b <= m P_a`` for every switch ``(a, b)``.

    With fixed gains the parameters are each region's closed-loop vertex matrices ``A_v - L_i C_v``
    and ``L_i diag(vbar)``; with ``design_gains`` the gains are unknowns (``Y_i = P_i L_i``), the
    parameters the vertex matrices ``A_v, C_v`` and ``vbar``, and an optional bound on each
    ``||L_i||_2`` takes the sufficient form of :mod:`.noise_gain` (scaled coordinates throughout).
    The common rate ``alpha`` and the coupling ``m`` are parameters too.
    """

    def __init__(self, n: int, p: int, vertices: list[int], pairs, w_ref: np.ndarray, *, design_gains: bool = False,
                 gain_bound: float | None = None, d: np.ndarray | None = None):
        self.design_gains = design_gains
        self.alpha = cp.Parameter(nonneg=True, value=1.0)
        self.m = cp.Parameter(nonneg=True, value=1.0)
        self.w = cp.Parameter(n, nonneg=True, value=np.asarray(w_ref, dtype=float))  # objective weights per state
        self.v = cp.Parameter(p, nonneg=True, value=np.ones(p))
        self.t = cp.Variable()
        self.P, self.Y, self.mu, self.A, self.C, self.LV = [], [], [], [], [], []
        cons = []
        for nv in vertices:
            P = cp.Variable((n, n), symmetric=True)
            mu = cp.Variable(p, nonneg=True)
            B = cp.Variable((n, n), symmetric=True)
            A = [cp.Parameter((n, n)) for _ in range(nv)]
            if design_gains:
                Y = cp.Variable((n, p))
                C = [cp.Parameter((p, n)) for _ in range(nv)]
                noise_col = -Y @ cp.diag(self.v)
                LV = None
            else:
                Y, C = None, []
                LV = cp.Parameter((n, p))
                noise_col = -P @ LV
            for v in range(nv):
                B11 = (P @ A[v] + A[v].T @ P - Y @ C[v] - C[v].T @ Y.T if design_gains else P @ A[v] + A[v].T @ P)
                blk = cp.bmat([[B11 + self.alpha * P, noise_col], [noise_col.T, -cp.diag(mu)]])
                cons.append(0.5 * (blk + blk.T) << 0)
            G = cp.bmat([[P, np.eye(n)], [np.eye(n), B]])
            cons += [0.5 * (G + G.T) >> 0, cp.multiply(self.w, cp.diag(B)) <= self.t, cp.sum(mu) == self.alpha]
            if design_gains and gain_bound is not None:
                dmax = float(d.max())
                kappa = cp.Variable(nonneg=True)
                cons.append(P >> kappa * np.diag((d / dmax) ** 2))
                H = cp.bmat([[P, Y], [Y.T, (gain_bound / dmax) ** 2 * kappa * np.eye(p)]])
                cons.append(0.5 * (H + H.T) >> 0)
            self.P.append(P)
            self.Y.append(Y)
            self.mu.append(mu)
            self.A.append(A)
            self.C.append(C)
            self.LV.append(LV)
        for a, b in pairs:
            for i, j in ((a, b), (b, a)):
                D = self.m * self.P[i] - self.P[j]
                cons.append(0.5 * (D + D.T) >> 0)
        self.problem = cp.Problem(cp.Minimize(self.t), cons)


def _jumps(P: list[np.ndarray], levels: list[float], pairs) -> dict:
    out = {}
    for i, j in pairs:
        for a, b in ((i, j), (j, i)):
            out[(a, b)] = _jump(P[a], levels[a], P[b], levels[b])
    return out


def _combine(regions: list[NoiseBoundDesign], pairs, dwell: float):
    """``(jumps, alpha, jump, needed, level, bound)`` of per-region ellipsoids (numpy, from their re-checked data)."""
    jumps = _jumps([d.P for d in regions], [d.level for d in regions], pairs)
    alpha = min(d.alpha for d in regions)
    jump = max(jumps.values(), default=1.0)
    needed = math.log(jump) / alpha if jump > 1.0 else 0.0
    q = jump * math.exp(-alpha * dwell)
    if not q < 1.0:
        return jumps, alpha, jump, needed, None, None
    level = max(1.0, jump * (1.0 - math.exp(-alpha * dwell)) / (1.0 - q))
    return jumps, alpha, jump, needed, level, math.sqrt(level) * np.array([d.bound for d in regions]).max(axis=0)


def switched_noise_bound(design: SwitchedDesign, noise, *, dwell: float | None = None, reference=None,
                         scaling: np.ndarray | None = None, design_gains: bool = False,
                         gain_bound: float | None = None, min_decay: float | None = None,
                         progress=None) -> SwitchedNoiseBound:
    """The ultimate error bound of ``design``'s switched observer under output noise ``|v_j| <= noise[j]``.

    Parameters
    ----------
    design : SwitchedDesign
        A switched-gain design (:func:`.switched.synthesize_switched`).
    noise : (p,) array
        Output-noise bounds, output order, model units.
    dwell : float, optional
        The dwell time to assume (default: ``design.dwell_guaranteed`` when the design has a
        maximum rate of the scheduling variable, else ``design.tau``).
    reference : (n,) array, optional
        Per-state sizes the bound is minimised against (default: the box half-widths).
    scaling : (n,) array, optional
        State scaling of the noise LMIs (default: the box half-widths).
    design_gains : bool, default False
        Design new gains on the design's regions that minimise the bound (``Y_i = P_i L_i``
        unknown), instead of bounding the design's own gains.
    gain_bound : float, optional
        With ``design_gains``: ``||L_i||_2 <= gain_bound`` (sufficient LMI form).
    min_decay : float, optional
        With ``design_gains``: the rate ``alpha`` (of ``V`` without noise) must reach this.
    progress : callable, optional
        Called with the number of SDPs solved so far.

    Returns
    -------
    SwitchedNoiseBound
        The best candidate (module docstring); ``bound`` is ``None`` when no candidate's dwell time
        needed is below the one assumed.

    See Also
    --------
    SwitchedNoiseBound : What it returns.
    synthesize_switched : The design it bounds.
    check_switched_noise_bound : Compares the bound with simulations.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A scalar plant ``x' = -sin(x) + u``, ``y = x``, with one gain for ``x < 0`` and one for ``x > 0``:

    >>> import casadi as ca

    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> plant = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), A=[[0.0]], C=[[1.0]],
    ...                               F=[[-1.0]], E=[[1.0]], f=(sine,), B=[[1.0]], name="scalar")
    >>> regions = regions_from_switch_points(plant, "x", -1.0, 1.0, [0.0], 0.1)
    >>> design = synthesize_switched(plant, regions, gain_bound=10.0, max_rate=2.0, overlap=0.1)
    >>> from hybobs_opt.lmi import switched_noise_bound
    >>> snb = switched_noise_bound(design, [0.01])
    >>> snb.holds, np.round(snb.bound, 4), np.round(snb.scaled(2.0).bound, 4)
    (True, array([0.009]), array([0.0179]))
    """
    from ..defaults import SWITCHED_NOISE_ALPHAS, SWITCHED_NOISE_COUPLINGS
    from ..lmi.lmi_model import box_scaling

    t0 = time.perf_counter()
    if not isinstance(design, SwitchedDesign):
        raise ModelError("design", "a SwitchedDesign", type(design).__name__)
    system = design.system
    n, p = system.n, system.p
    vbar, _, _, ref = _check_noise(system, noise, None, None, reference)
    if dwell is None:
        if design.dwell_guaranteed is not None:
            dwell, source = float(design.dwell_guaranteed), "the hysteresis at the maximum rate of the scheduling state"
        else:
            dwell, source = float(design.tau), "the design's dwell time tau, assumed"
    else:
        dwell, source = float(dwell), "given"
    if not (math.isfinite(dwell) and dwell > 0):
        raise ModelError("dwell", "a positive dwell time (s)", repr(dwell))
    done = [0]

    def tick():
        done[0] += 1
        if progress is not None:
            progress(done[0])

    if not design_gains and (gain_bound is not None or min_decay is not None):
        raise ModelError("gain_bound, min_decay", "only with design_gains=True (the design's gains are given)",
                         "a value")
    # each region on its own (its gain's, or its best gain's, invariant ellipsoid)
    alone = []
    for r in design.regions:
        alone.append(noise_optimal_design(system, r.bounds, vbar, gain_bound=gain_bound, min_decay=min_decay,
                                          reference=ref, scaling=scaling) if design_gains else
                     noise_optimal_design(system, r.bounds, vbar, gain=r.L, reference=ref, scaling=scaling))
        tick()
    best = (_combine(alone, design.pairs, dwell), alone, "per region")
    candidates = [_candidate_row(None, None, best[0], ref)]

    # jointly, with the switches coupled
    d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
    order = _output_order(system)
    verts = [_scaled_vertices(system, r.bounds, d) for r in design.regions]
    lmi = _JointNoiseLMI(n, p, [len(v[0]) for v in verts], design.pairs, (d / ref) ** 2, design_gains=design_gains,
                         gain_bound=gain_bound, d=d)
    r0 = max(a.worst_relative for a in alone)  # noise divisor: keeps the P_i of order one
    Lbars = [r.L[:, order] / d[:, None] for r in design.regions]
    for k, (As, Cs) in enumerate(verts):
        if design_gains:
            for par, A in zip(lmi.A[k], As):
                par.value = A
            for par, C in zip(lmi.C[k], Cs):
                par.value = C
        else:
            for par, A, C in zip(lmi.A[k], As, Cs):
                par.value = A - Lbars[k] @ C
            lmi.LV[k].value = Lbars[k] * (vbar[order] / r0)[None, :]
    lmi.v.value = vbar[order] / r0
    top = min(a.alpha_solved for a in alone)
    alphas = [a for a in top * np.asarray(SWITCHED_NOISE_ALPHAS) if min_decay is None or a >= min_decay]
    for alpha in alphas:
        for frac in SWITCHED_NOISE_COUPLINGS:
            m = 1.0 + (math.exp(alpha * dwell) - 1.0) * frac
            lmi.alpha.value, lmi.m.value = float(alpha), float(m)
            regions = _joint_point(lmi, system, design, verts, Lbars, vbar, order, d, ref, r0, alpha, solve_problem,
                                   gain_bound)
            tick()
            if regions is None:
                candidates.append({"alpha": float(alpha), "m": float(m), "status": "no checked point"})
                continue
            combined = _combine(regions, design.pairs, dwell)
            candidates.append(_candidate_row(float(alpha), float(m), combined, ref))
            if _better(combined, best[0], ref):
                best = (combined, regions, "joint")
    (jumps, alpha, jump, needed, level, bound), regions, method = best
    per_state = []
    if method == "joint" and bound is not None:
        # one certificate per state, each minimising that state's bound at the best rate
        w_all = (d / ref) ** 2
        a_best = best[1][0].alpha_solved
        for k in range(n):
            lmi.w.value = np.where(np.arange(n) == k, w_all, 0.0)
            lmi.alpha.value = float(a_best)
            best_k = None
            for frac in SWITCHED_NOISE_COUPLINGS:
                lmi.m.value = float(1.0 + (math.exp(a_best * dwell) - 1.0) * frac)
                regs = _joint_point(lmi, system, design, verts, Lbars, vbar, order, d, ref, r0, a_best, solve_problem,
                                    gain_bound)
                tick()
                if regs is None:
                    continue
                comb = _combine(regs, design.pairs, dwell)
                if comb[5] is not None and (best_k is None or comb[5][k] < best_k[0][5][k]):
                    best_k = (comb, regs)
            if best_k is not None and best_k[0][5][k] < bound[k]:
                per_state.append(StateCertificate(k, tuple(best_k[1]), *best_k[0]))
        if per_state:
            bound = bound.copy()
            for c in per_state:
                bound[c.state] = min(bound[c.state], c.bound[c.state])
    return SwitchedNoiseBound(design, tuple(regions), jumps, float(alpha), float(jump), dwell, source, float(needed),
                              level, bound, vbar, time.perf_counter() - t0, method, tuple(candidates),
                              "designed" if design_gains else "given", tuple(per_state))


def _worst(combined, ref) -> float:
    bound = combined[5]
    return float("inf") if bound is None else float(np.max(bound / ref))


def _better(new, old, ref) -> bool:
    from ..tolerances import SEARCH_IMPROVEMENT_RTOL

    return _worst(new, ref) < _worst(old, ref) * (1.0 - SEARCH_IMPROVEMENT_RTOL)


def _candidate_row(alpha, m, combined, ref) -> dict:
    jumps, a, jump, needed, level, bound = combined
    worst = _worst(combined, ref)
    return {"alpha": alpha, "m": m, "alpha_proven": a, "jump": jump, "dwell_needed": needed,
            "worst_relative": worst if np.isfinite(worst) else None}


def _joint_point(lmi, system, design, verts, Lbars, vbar, order, d, ref, r0, alpha, solve,
                 gain_bound: float | None = None) -> list | None:
    """The joint SDP's point as re-checked per-region designs, or ``None`` (no point, or a check failed)."""
    out = solve(lmi.problem)
    if out.status not in POINT_STATUSES:
        return None
    regions = []
    for k, (r, (As, Cs)) in enumerate(zip(design.regions, verts)):
        Pv, mv = lmi.P[k].value, lmi.mu[k].value
        if Pv is None or mv is None:
            return None
        P_bar = 0.5 * (np.asarray(Pv, dtype=float) + np.asarray(Pv, dtype=float).T) / r0 ** 2
        if not np.all(np.isfinite(P_bar)) or np.linalg.eigvalsh(P_bar)[0] <= 0:
            return None
        mu = np.clip(np.asarray(mv, dtype=float), 0.0, None)
        if lmi.design_gains:
            Yv = lmi.Y[k].value
            if Yv is None or not np.all(np.isfinite(Yv)):
                return None
            Lbar = np.linalg.solve(P_bar * r0 ** 2, np.asarray(Yv, dtype=float))
            L = np.zeros((system.n, system.p))
            L[:, order] = d[:, None] * Lbar
            if gain_bound is not None and np.linalg.norm(L, 2) > gain_bound * (1 + GAIN_BOUND_RTOL):
                return None
        else:
            Lbar, L = Lbars[k], r.L
        a2, mu2, blocks = _repair(P_bar, Lbar, float(alpha), mu, As, Cs, vbar[order], np.zeros((system.n, 0)))
        eigs = tuple(float(np.linalg.eigvalsh(B)[-1]) for B in blocks)
        if not (a2 > 0 and max(eigs) <= 0.0):
            return None
        level = float(np.sum(mu2)) / a2
        P = P_bar / d[:, None] / d[None, :]
        regions.append(NoiseBoundDesign(True, Status.OPTIMAL, L, 0.5 * (P + P.T), float(a2), mu2, level,
                                        _bounds_from(P_bar, d, level), ref, vbar, np.zeros(0), np.zeros((system.n, 0)),
                                        gain_bound, float(np.linalg.norm(L, 2)), "per_channel", lmi_max_eig=eigs,
                                        p_min_eig=float(np.linalg.eigvalsh(P_bar)[0]), alpha_solved=float(alpha),
                                        scaling=d, system=system, bounds=r.bounds))
    return regions
