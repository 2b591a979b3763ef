"""Mixed-logical-dynamical (big-M) encoding of a PWA system over a moving horizon.

The moving-horizon observer of Bemporad, Ferrari-Trecate and Morari (2000), eq. (10) of paper
002, minimises the output error over the initial state of a window of ``T`` samples subject to
the PWA dynamics of eq. (1).  The "if ``[x(k); u(k)] in Q_i``" of eq. (10) is turned into linear
constraints on binary and continuous variables with the mixed-logical-dynamical (MLD) construction
of Bemporad and Morari (1999), "Control of systems integrating logic, dynamics, and constraints",
Automatica 35(3):407-427:

* a binary ``delta[k, i]`` per window step ``k`` and mode ``i``, with ``sum_i delta[k, i] = 1``;
* the guard of mode ``i`` enforced only where ``delta[k, i] = 1``:
  ``G_i [x(k); u(k)] <= g_i + M^Q_i (1 - delta[k, i])``;
* continuous copies ``z[k, i] = delta[k, i] (A_i x(k) + B_i u(k) + a_i)`` of each mode's
  successor, by the four big-M inequalities
  ``m_i delta <= z <= M_i delta`` and
  ``m'_i (1 - delta) <= A_i x + B_i u + a_i - z <= M'_i (1 - delta)``,
  so that ``x(k + 1) = sum_i z[k, i]`` (plus an optional disturbance ``w(k)``);
* the same copies of the outputs ``C_i x + D_i u + c_i`` when the output map depends on the mode
  (when every mode shares ``(C, D, c)`` the output is affine in ``x(k)`` and needs no copies).

Every big-M constant is the value of a linear program over the state and input bounds (via
:func:`hybobs_opt.geometry.lp.solve_lp`), never a guessed number: ``M^Q_i`` is the largest value of each
guard row minus its right-hand side over ``X x U``; ``m_i, M_i`` are the extremes of each row of
the affine map over ``Q_i ∩ (X x U)`` (the only points where ``delta = 1`` places it) and
``m'_i, M'_i`` its extremes over ``X x U``.  These are the tightest constants for which the
encoding is exact on ``X x U``, which is why the states of the window are constrained to ``X``.

All decision variables are scaled (states by the half-widths of ``X``'s bounding box, DESIGN.md
"Scale before you solve") and every constraint row is normalised to a largest coefficient of one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ModelError
from ..geometry.lp import row_range
from ..geometry.polytope import Polytope
from ..systems.pwa import PWASystem
from ..tolerances import BIGM_IMPLIED_RTOL


@dataclass(frozen=True, eq=False)
class BigMConstants:
    """The LP-computed constants of the encoding (original units).

    Attributes
    ----------
    guard_rows : tuple of (G, g, M) per mode
        Rows ``G [x; u] <= g`` of ``Q_i`` kept in the encoding and their big-M ``M`` (the max of
        ``G_r [x; u] - g_r`` over ``X x U``).  Rows with ``M <= 0`` hold on all of ``X x U`` and
        are dropped.
    succ_on_guard, succ_on_domain : (s, n, 2) arrays
        ``[min, max]`` of each row of ``A_i x + B_i u + a_i`` over ``Q_i ∩ (X x U)`` and over
        ``X x U``.
    out_on_guard, out_on_domain : (s, p, 2) arrays or None
        The same for ``C_i x + D_i u + c_i`` (``None`` when the output map is mode-independent).
    output_range : (p, 2) array
        ``[min, max]`` of every mode's output over ``X x U`` (used to scale the output error).
    n_lps : int
        Number of LPs solved.
    """

    guard_rows: tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]
    succ_on_guard: np.ndarray
    succ_on_domain: np.ndarray
    out_on_guard: np.ndarray | None
    out_on_domain: np.ndarray | None
    output_range: np.ndarray
    n_lps: int


class _Support:
    """Extremes of affine functions over a polytope, by LPs in the unit-box coordinates of ``X x U``."""

    def __init__(self, system: PWASystem):
        half, centre = system.scales()
        self.half, self.centre = half, centre
        self.n_lps = 0

    def range(self, P: Polytope, c: np.ndarray, c0: float, what: str) -> tuple[float, float]:
        """``[min, max]`` of ``c' z + c0`` over ``P`` (``z = (x, u)``)."""
        # z = centre + half * s: LPs in s are well scaled even when states span 0.05 to 600.
        A = P.A * self.half[None, :]
        b = P.b - P.A @ self.centre
        cs = c * self.half
        base = float(c @ self.centre + c0)
        # an empty or unbounded guard is a model error (ModelError names it), a failed LP a SolverError
        r = row_range(A, b, cs, problem=f"big-M constant: {what}", field=f"guard / state and input bounds of {what}")
        self.n_lps += 2
        return float(r[0, 0] + base), float(r[0, 1] + base)


def big_m_constants(system: PWASystem) -> BigMConstants:
    """Compute every big-M constant of the MLD encoding by LPs over ``X x U``.

    Implements the bounds of the big-M construction of Bemporad & Morari (1999), applied to the
    PWA dynamics of eq. (1) of paper 002 with the bounded sets of eq. (2).

    Parameters
    ----------
    system : PWASystem

    Returns
    -------
    BigMConstants

    See Also
    --------
    encode_mld : Uses the constants.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import big_m_constants
    >>> bm = big_m_constants(plant)
    >>> type(bm).__name__
    'BigMConstants'
    """
    n, p, s = system.n, system.p, system.n_modes
    D = system.domain
    sup = _Support(system)
    half = sup.half
    guard_rows = []
    succ_g = np.empty((s, n, 2))
    succ_d = np.empty((s, n, 2))
    common = _common_output(system)
    out_g = None if common else np.empty((s, p, 2))
    out_d = None if common else np.empty((s, p, 2))
    out_all = np.empty((s, p, 2))
    for i, mode in enumerate(system.modes):
        Q = mode.guard.intersect(D)
        G, g = mode.guard.A, mode.guard.b
        M = np.empty(G.shape[0])
        for r in range(G.shape[0]):
            M[r] = sup.range(D, G[r], -g[r], f"guard row {r} of mode {i}")[1]
        # a row whose slack over X x U never goes negative constrains nothing: drop it
        scale = np.abs(G) @ half + np.abs(g)
        keep = M > BIGM_IMPLIED_RTOL * np.maximum(scale, 1.0)
        guard_rows.append((G[keep], g[keep], M[keep]))
        F = np.hstack([mode.A, mode.B])
        for j in range(n):
            succ_g[i, j] = sup.range(Q, F[j], mode.a[j], f"successor row {j} of mode {i} on its guard")
            succ_d[i, j] = sup.range(D, F[j], mode.a[j], f"successor row {j} of mode {i} on X x U")
        H = np.hstack([mode.C, mode.D])
        for j in range(p):
            out_all[i, j] = sup.range(D, H[j], mode.c[j], f"output row {j} of mode {i} on X x U")
            if not common:
                out_d[i, j] = out_all[i, j]
                out_g[i, j] = sup.range(Q, H[j], mode.c[j], f"output row {j} of mode {i} on its guard")
    output_range = np.stack([out_all[:, :, 0].min(axis=0), out_all[:, :, 1].max(axis=0)], axis=1)
    return BigMConstants(tuple(guard_rows), succ_g, succ_d, out_g, out_d, output_range, sup.n_lps)


def _common_output(system: PWASystem) -> bool:
    """True when every mode has the same output map ``(C, D, c)`` (no output copies needed)."""
    m0 = system.modes[0]
    return all(np.array_equal(md.C, m0.C) and np.array_equal(md.D, m0.D) and np.array_equal(md.c, m0.c)
               for md in system.modes[1:])


@dataclass(frozen=True, eq=False)
class MLDEncoding:
    """The MLD form of eq. (10)'s constraints over a window of ``T`` samples.

    Decision vector ``v`` (scaled) = ``[xi0, delta, zeta, zeta_y, omega]`` where ``x(0) = cx + hx * xi0``,
    ``delta`` are the ``T * s`` binaries (row-major ``[k, i]``), ``zeta`` the scaled successor copies
    (``z[k, i] = hx * zeta[k, i]``, ``k < T - 1``), ``zeta_y`` the scaled output copies (empty when the
    output map is common), ``omega`` the scaled disturbances (``w(k) = hx * omega[k]``, empty when
    disabled).  With the stacked window input ``U = [u(0); ...; u(T-1)]``:

    * constraints: ``lo <= A v + BU U + BP P <= hi`` (rows with ``lo == hi`` are equalities; ``P``
      are the extension's parameters of :meth:`set_parameters`, none without an extension);
    * bounds: ``lb <= v <= ub`` (``delta`` in ``[0, 1]``, marked by ``discrete``);
    * states: ``x(k) = Xmap[k] v + Xoff[k]``;
    * outputs: ``Y^ = Ymap v + YU U + Yoff`` (stacked ``y^(0) ... y^(T-1)``).

    Build with :func:`encode_mld`.

    Parameters
    ----------
    system : PWASystem
        The model.
    T : int
        Window length.
    disturbances : bool
        Whether the disturbances ``omega`` are variables.
    A, BU : arrays
        Constraint rows ``lo <= A v + BU U <= hi``.
    lo, hi : arrays
        Their bounds (equal for equality rows).
    lb, ub : arrays
        Variable bounds.
    discrete : bool array
        The binary variables ``delta``.
    Xmap, Xoff : arrays
        ``x(k) = Xmap[k] v + Xoff[k]``, shapes ``(T, n, n_vars)`` and ``(T, n)``.
    Ymap, YU, Yoff : arrays
        ``Y^ = Ymap v + YU U + Yoff``.
    slices : dict of str to slice
        Position of each block (``"xi0"``, ``"delta"``, ``"zeta"``, ``"zeta_y"``, ``"omega"``) in ``v``.
    big_m : BigMConstants, optional
        The constants the rows were built with.
    state_scale : (n,) array, optional
        The state scale ``hx`` (``None``: the half-widths of the state box).
    BP : (nr, n_params) array, optional
        Dependence of the rows on the extension's parameters (``None``: no extension).

    See Also
    --------
    encode_mld : Builds one.
    big_m_constants : Its big-M constants.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import encode_mld
    >>> enc = encode_mld(plant, 3)
    >>> enc.n_vars, enc.n_constraints, int(enc.discrete.sum())
    (30, 99, 9)
    >>> enc.A.shape
    (99, 30)
    """

    system: PWASystem
    T: int
    disturbances: bool
    A: np.ndarray
    BU: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    discrete: np.ndarray
    Xmap: np.ndarray
    Xoff: np.ndarray
    Ymap: np.ndarray
    YU: np.ndarray
    Yoff: np.ndarray
    slices: dict = field(default_factory=dict)
    big_m: BigMConstants | None = None
    state_scale: np.ndarray | None = None
    BP: np.ndarray | None = None
    _params: dict = field(default_factory=dict, repr=False, init=False)

    @property
    def n_params(self) -> int:
        """Number of extra (extension) parameters entering the row bounds through ``BP``."""
        return 0 if self.BP is None else self.BP.shape[1]

    def set_parameters(self, P: np.ndarray | None) -> None:
        """Values of the extension's parameters for the window being solved (``BP`` columns).

        Parameters
        ----------
        P : (n_params,) ndarray or None
            The stacked parameter values (:class:`~hybobs_opt.mhe.formulation.MHEFormulation`);
            ``None`` clears them.
        """
        self._params["P"] = None if P is None else np.asarray(P, dtype=float).reshape(self.n_params)

    @property
    def n_vars(self) -> int:
        return self.A.shape[1]

    @property
    def n_constraints(self) -> int:
        return self.A.shape[0]

    @property
    def x_scale(self) -> tuple[np.ndarray, np.ndarray]:
        """``(hx, cx)``: state scale (default the half-widths of the state box) and box centre."""
        half, centre = self.system.scales()
        n = self.system.n
        return (half[:n] if self.state_scale is None else self.state_scale), centre[:n]

    def bounds(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row bounds ``lo - BU U``, ``hi - BU U`` for the stacked window input ``U``.

        Parameters
        ----------
        U : (T m,) ndarray
            Stacked window input ``[u(0); ...; u(T-1)]``.

        Returns
        -------
        tuple of two ndarray
            Row bounds ``lo - BU U``, ``hi - BU U`` for the stacked window input ``U``.
        """
        shift = self.BU @ U
        if self.n_params:
            P = self._params.get("P")
            if P is None:
                raise ModelError("parameters", f"values of the {self.n_params} extension parameters of the window",
                                 "none set (MHEObserver.set_parameter)")
            shift = shift + self.BP @ P
        return self.lo - shift, self.hi - shift

    def states(self, v: np.ndarray) -> np.ndarray:
        """``(T, n)`` window states of the decision vector ``v``.

        Parameters
        ----------
        v : (n_vars,) ndarray
            Scaled decision vector.

        Returns
        -------
        ndarray
            ``(T, n)`` window states of the decision vector ``v``.
        """
        return np.einsum("kij,j->ki", self.Xmap, v) + self.Xoff

    def outputs(self, v: np.ndarray, U: np.ndarray) -> np.ndarray:
        """``(T, p)`` window outputs.

        Parameters
        ----------
        v : (n_vars,) ndarray
            Scaled decision vector.
        U : (T m,) ndarray
            Stacked window input.

        Returns
        -------
        ndarray
            ``(T, p)`` window outputs.
        """
        return (self.Ymap @ v + self.YU @ U + self.Yoff).reshape(self.T, self.system.p)

    def modes(self, v: np.ndarray) -> np.ndarray:
        """``(T,)`` mode index of each step (largest ``delta``).

        Parameters
        ----------
        v : (n_vars,) ndarray
            Scaled decision vector.

        Returns
        -------
        ndarray
            ``(T,)`` mode index of each step (largest ``delta``).
        """
        return np.argmax(v[self.slices["delta"]].reshape(self.T, self.system.n_modes), axis=1)

    def disturbance(self, v: np.ndarray) -> np.ndarray:
        """``(T - 1, n)`` disturbances ``w(k)`` (zeros when disabled).

        Parameters
        ----------
        v : (n_vars,) ndarray
            Scaled decision vector.

        Returns
        -------
        ndarray
            ``(T - 1, n)`` disturbances ``w(k)`` (zeros when disabled).
        """
        n = self.system.n
        if not self.disturbances:
            return np.zeros((self.T - 1, n))
        return v[self.slices["omega"]].reshape(self.T - 1, n) * self.x_scale[0]

    def point(self, x0: np.ndarray, modes: np.ndarray, U: np.ndarray, W: np.ndarray | None = None) -> np.ndarray:
        """The decision vector of a trajectory: start ``x0``, mode sequence ``modes``, inputs ``U``.

        The states follow ``x(k + 1) = A_q x + B_q u + a_q + w(k)`` with ``q = modes[k]`` (guards
        are not checked; :meth:`violation` does that).  Used for warm starts and tests.

        Parameters
        ----------
        x0 : (n,) array_like
            Window-start state ``x(0)``.
        modes : (T,) int array_like
            0-based mode index of each step.
        U : array_like
            Window inputs, ``(T m,)`` stacked or ``(T, m)``.
        W : (T - 1, n) ndarray, optional
            Disturbances ``w(k)``; ``None`` means none.

        Returns
        -------
        (n_vars,) ndarray
            The scaled decision vector (see :meth:`pack`).
        """
        sysm, T = self.system, self.T
        Uw = np.asarray(U, dtype=float).reshape(T, sysm.m)
        X = np.empty((T, sysm.n))
        X[0] = np.asarray(x0, dtype=float)
        for k in range(T - 1):
            md = sysm.modes[int(modes[k])]
            X[k + 1] = md.A @ X[k] + md.B @ Uw[k] + md.a + (W[k] if W is not None else 0.0)
        return self.pack(X, modes, Uw, W)

    def pack(self, X: np.ndarray, modes: np.ndarray, U: np.ndarray, W: np.ndarray | None = None) -> np.ndarray:
        """The decision vector of a known trajectory: states ``X`` (``(T, n)``), modes, inputs, disturbances.

        Vectorised counterpart of :meth:`point` for a trajectory that is already simulated.

        Parameters
        ----------
        X : (T, n) ndarray
            Window states.
        modes : (T,) int array_like
            0-based mode index of each step.
        U : array_like
            Window inputs, ``(T m,)`` stacked or ``(T, m)`` (used for the output copies only).
        W : (T - 1, n) ndarray, optional
            Disturbances ``w(k)`` (``X[k + 1]`` includes them); ``None`` means none.

        Returns
        -------
        (n_vars,) ndarray
            The scaled decision vector.
        """
        sysm, T = self.system, self.T
        n, s = sysm.n, sysm.n_modes
        hx, cx = self.x_scale
        modes = np.asarray(modes, dtype=int)
        v = np.zeros(self.n_vars)
        v[self.slices["xi0"]] = (X[0] - cx) / hx
        ks = np.arange(T)
        v[self.slices["delta"].start + ks * s + modes] = 1.0
        if T > 1:
            succ = X[1:] if W is None else X[1:] - W
            zeta = np.zeros((T - 1, s, n))
            zeta[ks[:-1], modes[:-1]] = succ / hx
            v[self.slices["zeta"]] = zeta.reshape(-1)
        if self.slices["zeta_y"].stop > self.slices["zeta_y"].start:
            Uw = np.asarray(U, dtype=float).reshape(T, sysm.m)
            zy = np.zeros((T, s, sysm.p))
            for k in range(T):
                md = sysm.modes[int(modes[k])]
                zy[k, modes[k]] = (md.C @ X[k] + md.D @ Uw[k] + md.c) / self._hy()
            v[self.slices["zeta_y"]] = zy.reshape(-1)
        if self.disturbances and W is not None:
            v[self.slices["omega"]] = (np.asarray(W, dtype=float) / hx).reshape(-1)
        return v

    def _hy(self) -> np.ndarray:
        r = self.big_m.output_range
        return np.maximum(np.abs(r).max(axis=1), 1e-300)

    def violation(self, v: np.ndarray, U: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> float:
        """Largest violation of the (row-normalised) constraints, bounds and integrality at ``v``.

        ``bounds`` are :meth:`bounds` of ``U`` when already computed.

        Parameters
        ----------
        v : (n_vars,) ndarray
            Scaled decision vector.
        U : (T m,) ndarray
            Stacked window input.
        bounds : (lo, hi) pair of ndarray, optional
            Row bounds from :meth:`bounds` of ``U``, to skip recomputing them.

        Returns
        -------
        float
            Largest violation of the (row-normalised) constraints, bounds and integrality at ``v``.
        """
        lo, hi = self.bounds(U) if bounds is None else bounds
        Av = self.A @ v
        d = v[self.discrete]
        # one reduction: infinite bounds give -inf entries, which never win
        r = np.concatenate([lo - Av, Av - hi, self.lb - v, v - self.ub, np.abs(d - np.round(d)), [0.0]])
        return float(r.max())


@dataclass(frozen=True, eq=False)
class MLDSymbols:
    """The MLD constraints of eq. (10) as CasADi SX expressions (built by :func:`mld_expressions`).

    The decision vector ``v`` has the layout of :class:`MLDEncoding` (``slices``); the stacked
    window input ``U`` is a parameter.  ``rows`` is the column of constraint expressions with the
    constant bounds ``lo <= rows(v, U) <= hi`` (not yet normalised); ``x[k]`` and ``y_hat[k]``
    are the window states and outputs in original units, ``delta[k]`` the ``s`` binaries of step
    ``k``, ``w[k]`` the disturbances in original units (empty without them).
    """

    v: Any
    U: Any
    rows: Any
    lo: np.ndarray
    hi: np.ndarray
    x: list
    y_hat: list
    delta: list
    w: list
    lb: np.ndarray
    ub: np.ndarray
    discrete: np.ndarray
    slices: dict
    hx: np.ndarray
    cx: np.ndarray
    hy: np.ndarray
    big_m: BigMConstants
    disturbances: bool
    default_scale: bool


def mld_expressions(system: PWASystem, T: int, *, disturbances: bool = False,
                    big_m: BigMConstants | None = None, state_scale: np.ndarray | None = None) -> MLDSymbols:
    """Write the MLD / big-M constraints of eq. (10) for a window of ``T`` samples in CasADi SX.

    The mixed-logical-dynamical form of Bemporad & Morari (1999) of the PWA system of eq. (1) of
    paper 002 (module docstring), as symbolic expressions of the scaled decision vector ``v`` and
    the window input ``U``: one-hot rows, ``x(k) in X``, the guards with their big-M constants and
    the four big-M rows of every successor and output copy, in the order :func:`encode_mld`
    extracts them.

    Parameters
    ----------
    system : PWASystem
        The model, with bounded ``X`` and ``U`` (eq. 2).
    T : int
        Window length (``T >= 1``).
    disturbances : bool
        Whether ``x(k + 1) = f_i(x(k), u(k)) + w(k)`` has disturbance variables.
    big_m : BigMConstants, optional
        Precomputed constants (:func:`big_m_constants`).
    state_scale : (n,) array, optional
        Unit of each scaled state variable (default: the half-widths of ``X``'s bounding box).

    Returns
    -------
    MLDSymbols

    Raises
    ------
    ModelError
        If ``system`` is not a PWASystem, ``T < 1`` or ``state_scale`` is not ``n`` positive numbers.
    """
    import casadi as ca

    if not isinstance(system, PWASystem):
        raise ModelError("system", "a PWASystem", type(system).__name__)
    if isinstance(T, bool) or not isinstance(T, (int, np.integer)) or T < 1:
        raise ModelError("T", "an integer horizon T >= 1", repr(T))
    T = int(T)
    bm = big_m_constants(system) if big_m is None else big_m
    n, m, p, s = system.n, system.m, system.p, system.n_modes
    half, centre = system.scales()
    hx, cx = half[:n].copy(), centre[:n].copy()
    if state_scale is not None:
        hx = np.asarray(state_scale, dtype=float).reshape(-1)
        if hx.shape != (n,) or not np.all(np.isfinite(hx) & (hx > 0)):
            raise ModelError("state_scale", f"{n} positive finite numbers", f"{np.asarray(state_scale).tolist()}")
    common = bm.out_on_guard is None
    hy = np.maximum(np.abs(bm.output_range).max(axis=1), 1e-300)

    sizes = [("xi0", n), ("delta", T * s), ("zeta", (T - 1) * s * n),
             ("zeta_y", 0 if common else T * s * p), ("omega", (T - 1) * n if disturbances else 0)]
    slices, off = {}, 0
    for name, size in sizes:
        slices[name] = slice(off, off + size)
        off += size
    nv = off
    v = ca.SX.sym("v", nv)
    U = ca.SX.sym("U", T * m)

    def block(name: str, start: int, size: int):
        a = slices[name].start + start
        return v[a:a + size]

    u = [U[k * m:(k + 1) * m] for k in range(T)]
    delta = [block("delta", k * s, s) for k in range(T)]
    zeta = [[block("zeta", (k * s + i) * n, n) for i in range(s)] for k in range(T - 1)]
    zeta_y = [[block("zeta_y", (k * s + i) * p, p) for i in range(s)] for k in range(T)] if not common else []
    w = [ca.DM(hx) * block("omega", k * n, n) for k in range(T - 1)] if disturbances else []
    # states: x(0) = cx + hx xi0; x(k+1) = sum_i hx zeta[k, i] (+ w(k))
    x = [ca.DM(cx) + ca.DM(hx) * block("xi0", 0, n)]
    for k in range(T - 1):
        nxt = ca.DM(hx) * zeta[k][0]
        for i in range(1, s):
            nxt = nxt + ca.DM(hx) * zeta[k][i]
        x.append(nxt + w[k] if disturbances else nxt)

    rows, lo, hi = [], [], []

    def add(expr, a: float, b: float) -> None:
        rows.append(expr)
        lo.append(a)
        hi.append(b)

    def dot(row: np.ndarray, vec):
        return ca.mtimes(ca.DM(row.reshape(1, -1)), vec)

    def copy_rows(d, z, f, lo_g: float, hi_g: float, lo_d: float, hi_d: float) -> None:
        # lo_g delta <= z <= hi_g delta (the copy vanishes when the mode is off, bounds over its
        # guard) and lo_d (1 - delta) <= f - z <= hi_d (1 - delta) (it equals f when the mode is
        # on, bounds over X x U); Bemporad & Morari (1999)
        add(z - hi_g * d, -np.inf, 0.0)
        add(z - lo_g * d, 0.0, np.inf)
        add(f - z + hi_d * d, -np.inf, hi_d)
        add(f - z + lo_d * d, lo_d, np.inf)

    X = system.state_bounds
    box_X = _is_axis_box(X)
    for k in range(T):
        add(ca.sum1(delta[k]), 1.0, 1.0)  # one mode per step
        if k > 0 or not box_X:  # x(k) in X (x(0) by its variable bounds when X is a box)
            for r in range(X.n_constraints):
                add(dot(X.A[r], x[k]), -np.inf, float(X.b[r]))
        for i, mode in enumerate(system.modes):
            d = delta[k][i]
            G, g, M = bm.guard_rows[i]
            for r in range(G.shape[0]):  # G_x x(k) + G_u u(k) + M delta <= g + M
                add(dot(G[r, :n], x[k]) + M[r] * d + dot(G[r, n:], u[k]), -np.inf, float(g[r] + M[r]))
            if k < T - 1:
                for j in range(n):
                    f = dot(mode.A[j], x[k]) + mode.a[j] + dot(mode.B[j], u[k])
                    copy_rows(d, hx[j] * zeta[k][i][j], f, *bm.succ_on_guard[i, j], *bm.succ_on_domain[i, j])
            if not common:
                for j in range(p):
                    f = dot(mode.C[j], x[k]) + mode.c[j] + dot(mode.D[j], u[k])
                    copy_rows(d, hy[j] * zeta_y[k][i][j], f, *bm.out_on_guard[i, j], *bm.out_on_domain[i, j])

    m0 = system.modes[0]
    if common:
        y_hat = [ca.mtimes(ca.DM(m0.C), x[k]) + ca.mtimes(ca.DM(m0.D), u[k]) + ca.DM(m0.c) for k in range(T)]
    else:
        y_hat = []
        for k in range(T):
            yk = ca.DM(hy) * zeta_y[k][0]
            for i in range(1, s):
                yk = yk + ca.DM(hy) * zeta_y[k][i]
            y_hat.append(yk)

    # variable bounds (scaled)
    inf = np.inf
    lb = np.full(nv, -inf)
    ub = np.full(nv, inf)
    xlo, xhi = cx - half[:n], cx + half[:n]
    lb[slices["xi0"]], ub[slices["xi0"]] = -half[:n] / hx, half[:n] / hx
    lb[slices["delta"]], ub[slices["delta"]] = 0.0, 1.0
    zlo = np.minimum(bm.succ_on_guard[:, :, 0], 0.0) / hx
    zhi = np.maximum(bm.succ_on_guard[:, :, 1], 0.0) / hx
    lb[slices["zeta"]] = np.tile(zlo.reshape(-1), T - 1)
    ub[slices["zeta"]] = np.tile(zhi.reshape(-1), T - 1)
    if not common:
        lb[slices["zeta_y"]] = np.tile((np.minimum(bm.out_on_guard[:, :, 0], 0.0) / hy).reshape(-1), T)
        ub[slices["zeta_y"]] = np.tile((np.maximum(bm.out_on_guard[:, :, 1], 0.0) / hy).reshape(-1), T)
    if disturbances:
        # w = x(k+1) - f(x(k), u(k)) with x(k+1) in X: these bounds are implied, never binding
        wlo = (xlo - bm.succ_on_domain[:, :, 1].max(axis=0)) / hx
        whi = (xhi - bm.succ_on_domain[:, :, 0].min(axis=0)) / hx
        lb[slices["omega"]] = np.tile(wlo, T - 1)
        ub[slices["omega"]] = np.tile(whi, T - 1)
    discrete = np.zeros(nv, dtype=bool)
    discrete[slices["delta"]] = True
    return MLDSymbols(v, U, ca.vertcat(*rows), np.array(lo, dtype=float), np.array(hi, dtype=float), x, y_hat,
                      delta, w, lb, ub, discrete, slices, hx, cx, hy, bm, bool(disturbances), state_scale is None)


def affine_parts(expr, var, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(J_var, J_params, const)`` of an expression affine in ``var`` and ``params``, by CasADi.

    The Jacobians ``casadi.jacobian(expr, var)``, ``casadi.jacobian(expr, params)`` and the value
    at ``var = 0, params = 0``, evaluated to dense numpy once.  Whether ``expr`` is affine is the
    caller's check (the MLD rows are affine by construction; an extension's terms are checked
    by :class:`~hybobs_opt.mhe.formulation.MHEFormulation`).

    Parameters
    ----------
    expr : casadi.SX
        Column of expressions.
    var, params : casadi.SX
        Columns of symbols.

    Returns
    -------
    (J_var, J_params, const) : ndarrays
        ``expr = J_var var + J_params params + const``.
    """
    import casadi as ca

    F = ca.Function("affine_parts", [var, params],
                    [ca.jacobian(expr, var), ca.jacobian(expr, params), expr])
    Jv, Jp, c = F(np.zeros(var.numel()), np.zeros(params.numel()))
    return np.array(Jv.full(), dtype=float), np.array(Jp.full(), dtype=float), np.array(c.full(), dtype=float).reshape(-1)


def mld_encoding(sym: MLDSymbols, system: PWASystem, T: int, extra_rows=None, params=None) -> MLDEncoding:
    """Extract the numpy :class:`MLDEncoding` from the symbolic constraints (once, at construction).

    ``A = jacobian(rows, v)``, ``BU = jacobian(rows, U)`` and the constant part moved into the
    bounds; every row is then normalised to a largest coefficient of one in ``v``.  ``extra_rows``
    ``(expr, lo, hi)`` are appended (an extension's affine constraints) and ``params`` is the SX
    column of its extra parameters (their map goes into ``BP``).

    Parameters
    ----------
    sym : MLDSymbols
        The symbolic rows (:func:`mld_expressions`).
    system : PWASystem
        The model.
    T : int
        Window length.
    extra_rows : (casadi.SX, ndarray, ndarray), optional
        Rows ``lo <= expr <= hi`` appended after the MLD rows.
    params : casadi.SX, optional
        The extension's parameters.

    Returns
    -------
    MLDEncoding
    """
    import casadi as ca

    rows, lo, hi = sym.rows, sym.lo, sym.hi
    if extra_rows is not None and extra_rows[0].numel():
        rows = ca.vertcat(rows, extra_rows[0])
        lo, hi = np.concatenate([lo, extra_rows[1]]), np.concatenate([hi, extra_rows[2]])
    P = ca.SX.sym("P", 0) if params is None else params
    A, BUP, c = affine_parts(rows, sym.v, ca.vertcat(sym.U, P))
    nu = sym.U.numel()
    BU, BP = BUP[:, :nu], BUP[:, nu:]
    lo, hi = lo - c, hi - c
    norm = np.max(np.abs(A), axis=1) if A.size else np.ones(A.shape[0])
    norm = np.where(norm > 0, norm, 1.0)
    A, BU, BP, lo, hi = A / norm[:, None], BU / norm[:, None], BP / norm[:, None], lo / norm, hi / norm
    nv = sym.v.numel()
    Xmap, Xoff = np.zeros((T, system.n, nv)), np.zeros((T, system.n))
    for k in range(T):
        Xmap[k], _, Xoff[k] = affine_parts(sym.x[k], sym.v, sym.U)
    Ymap, YU, Yoff = affine_parts(ca.vertcat(*sym.y_hat), sym.v, sym.U)
    return MLDEncoding(system, T, sym.disturbances, A, BU, lo, hi, sym.lb, sym.ub, sym.discrete, Xmap, Xoff, Ymap, YU,
                       Yoff, sym.slices, sym.big_m, None if sym.default_scale else sym.hx, BP=BP)


def encode_mld(system: PWASystem, T: int, *, disturbances: bool = False,
               big_m: BigMConstants | None = None, state_scale: np.ndarray | None = None) -> MLDEncoding:
    """Derive the MLD / big-M encoding of eq. (10)'s constraints for a window of ``T`` samples.

    Implements the mixed-logical-dynamical form of Bemporad & Morari (1999) for the PWA system of
    eq. (1) of paper 002, as used by the moving-horizon observer of eq. (10) (Bemporad,
    Ferrari-Trecate & Morari, 2000).  See the module docstring for the constraints: they are
    written once as CasADi expressions (:func:`mld_expressions`) and their matrices extracted by
    ``casadi.jacobian`` (:func:`mld_encoding`).

    Parameters
    ----------
    system : PWASystem
        The model, with bounded ``X`` and ``U`` (eq. 2): every big-M constant comes from them.
    T : int
        Window length (``T >= 1``).
    disturbances : bool
        Add state disturbances ``x(k + 1) = f_i(x(k), u(k)) + w(k)`` (penalised by the observer).
    big_m : BigMConstants, optional
        Precomputed constants (:func:`big_m_constants`), e.g. shared by several horizons.
    state_scale : (n,) array, optional
        Unit of each scaled state variable (``x = cx + state_scale * xi``); default the half-widths
        of ``X``'s bounding box.

    Returns
    -------
    MLDEncoding

    Raises
    ------
    ModelError
        If ``system`` is not a PWASystem or ``T < 1``.

    See Also
    --------
    MLDEncoding : What it returns.
    big_m_constants : The constants it uses.
    MHEFormulation : The full program of eq. (10).

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import encode_mld
    >>> enc = encode_mld(plant, 3)

    ``T * s`` mode binaries (3 samples, 3 modes):

    >>> int(enc.discrete.sum()), enc.T
    (9, 3)
    """
    sym = mld_expressions(system, T, disturbances=disturbances, big_m=big_m, state_scale=state_scale)
    return mld_encoding(sym, system, int(T))


def _is_axis_box(P: Polytope) -> bool:
    """True when every row of ``P`` has a single non-zero (the set is its bounding box)."""
    return bool(np.all(np.count_nonzero(P.A, axis=1) <= 1))
