"""The moving-horizon problem (10) of paper 002 written once in CasADi, and the matrices every
backend takes from it.

Eq. (10) of Bemporad, Ferrari-Trecate & Morari (2000) with the optional terms of Ferrari-Trecate,
Mignone & Morari (2002) is posed on CasADi SX expressions of the scaled decision vector and of
the window's data, which are CasADi *parameters*:

* decision vector ``v`` of the MLD encoding (:func:`~hybobs_opt.mhe.mld.mld_expressions`):
  window-start state, binaries ``delta``, successor and output copies, disturbances; for norms
  1 / inf also the epigraph variables ``e`` of the norms (one per residual entry for norm 1, one
  per residual block for norm inf), so that the MILP's decision vector is ``z = [v; e]``;
* parameters ``p = [U; Y; x_bar; P]``: the stacked window inputs and outputs, the arrival prior
  and the parameters an extension adds (:class:`MHEExtension`);
* constraints: the MLD rows ``lo <= rows(v, U) <= hi``, an extension's affine rows, and for norms
  1 / inf the epigraph rows ``+-r(v, p) / j_s - E e <= 0``;
* cost: norm 2, ``J = ||r(v, p)||^2 + J_ext`` with ``r`` the stacked weighted residual of
  :mod:`hybobs_opt.mhe.residual`; norms 1 / inf, ``sum(e) + J_ext``.

:class:`MHEFormulation` extracts everything the solvers need ONCE, at construction, by
``casadi.jacobian`` / ``casadi.hessian`` evaluated to numpy: the constraint matrix, the affine
dependence of the row bounds on ``p``, the cost's Hessian (norm 2) or cost vector (norms
1 / inf) and the affine dependence of the linear term on ``p``.  The per-step work is then numpy
only (a few matrix-vector products), as before the problem was written in CasADi.  The scaling
(states by the half-widths of ``X``) and the row normalisation (largest coefficient one) are
applied to the extracted rows; the big-M constants are LP values (:func:`big_m_constants`).

An extension (the ``extend`` callable of :class:`~hybobs_opt.mhe.MHEObserver`) adds cost terms,
affine constraints and parameters on the same symbols; they go into the same extracted matrices,
so every backend, the exact prefix search and the uniqueness program see them (see
:class:`MHEExtension` for what is accepted and how it is checked).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..errors import ModelError
from ..systems.pwa import PWASystem
from ..tolerances import MHE_EXTENSION_PSD_RTOL, MHE_EXTENSION_RANGE_RTOL
from .mld import BigMConstants, MLDEncoding, MLDSymbols, affine_parts, mld_encoding, mld_expressions
from .residual import StackedResidual

__all__ = ["MHEExtension", "MHEFormulation"]


def _ca():
    import casadi as ca

    return ca


class MHEExtension:
    """The symbols of one window of eq. (10), handed to an ``extend`` callable.

    ``MHEObserver(..., extend=fn)`` calls ``fn(ext)`` once, at construction, with this object;
    ``fn`` adds cost terms, affine constraints and parameters in CasADi SX expressions of the
    attributes below.  Everything added goes into the matrices every backend receives
    (:class:`MHEFormulation`) and into the numpy model of the window
    (:class:`~hybobs_opt.mhe.window.WindowModel`: the cost of a trajectory, the problem of one
    mode sequence, the prefixes of the exact search).

    Attributes
    ----------
    T, n, m, p, n_modes : int
        Window length and the system's dimensions.
    norm : {"2", "1", "inf"}
        The observer's norm (it decides what :meth:`add_cost` accepts).
    x : list of T SX (n, 1)
        Window states ``x(t-T+1+k)``, original units (affine in the decision vector).
    y_hat : list of T SX (p, 1)
        Model outputs of the window.
    u, y : list of T SX (m, 1) / (p, 1)
        The window's inputs and measured outputs (parameters).
    x_bar : SX (n, 1)
        The arrival prior (parameter).
    delta : list of T SX (n_modes, 1)
        The mode binaries of each step.
    w : list of T - 1 SX (n, 1)
        The disturbances, original units (empty without ``disturbance_weight``).

    See Also
    --------
    MHEObserver : Takes the ``extend`` callable.
    MHEFormulation : Holds the extension's terms.

    Notes
    -----
    * :meth:`add_cost` -- norm 2: a convex quadratic in the decision variables whose linear part
      lies in the range of its Hessian (a sum of squares plus a constant of the data, e.g.
      ``rho * ||x[0] - x_ref||^2``), with coefficients affine in the parameters; it is written as
      extra rows of the stacked residual, so the cost stays a sum of squares (the zero-cost
      certificate and the prefix search's bounds stay valid).  A constant that is not part of
      the sum of squares (``rho * ||x[0] - x_ref||^2 + 5``: the 5) does not change the
      minimiser and is dropped: costs are reported without it.  Norms 1 / inf: a linear term
      with constant coefficients (reported as written, constant included).  Anything else is a
      :class:`~hybobs_opt.errors.ModelError`
      saying which condition failed (not quadratic, not convex, linear part outside the
      Hessian's range, not linear, coefficients depending on the data).
    * :meth:`add_constraint` -- ``lo <= expr <= hi`` with ``expr`` affine in the decision
      variables, the inputs ``u`` and the extension's parameters (not in ``y`` or ``x_bar``).
    * :meth:`add_parameter` -- a parameter of the given shape, with a fixed value or one set per
      step by :meth:`MHEObserver.set_parameter <hybobs_opt.mhe.MHEObserver.set_parameter>`.

    Examples
    --------
    A quadratic pull of the window-start state towards a reference given each step:

    >>> import casadi
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver, MHESettings
    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> def pull(ext):
    ...     x_ref = ext.add_parameter("x_ref", ext.n)
    ...     ext.add_cost(1e3 * casadi.sumsqr(ext.x[0] - x_ref))
    ...     ext.add_constraint(ext.x[0][0], lo=-0.05, hi=0.05)    # |theta(t-T+1)| <= 0.05
    >>> obs = MHEObserver(plant, 3, extend=pull,
    ...                   settings=MHESettings(check_uniqueness=False))
    >>> obs.set_parameter("x_ref", [0.0, 10.0, 10.0])
    """

    def __init__(self, sym: MLDSymbols, norm: str, U, Y, xbar, dims: tuple[int, int, int, int, int]):
        ca = _ca()
        T, n, m, p, s = dims
        self.T, self.n, self.m, self.p, self.n_modes, self.norm = T, n, m, p, s, norm
        self.x, self.y_hat, self.delta, self.w = list(sym.x), list(sym.y_hat), list(sym.delta), list(sym.w)
        self.u = [U[k * m:(k + 1) * m] for k in range(T)]
        self.y = [Y[k * p:(k + 1) * p] for k in range(T)]
        self.x_bar = xbar
        self._ca = ca
        self.costs: list = []
        self.rows: list[tuple[Any, np.ndarray, np.ndarray]] = []
        self.params: list[tuple[str, Any, tuple[int, ...], np.ndarray | None]] = []

    def add_parameter(self, name: str, shape=1, value=None):
        """A parameter of the window problem; returns its SX symbol.

        Parameters
        ----------
        name : str
            Its name (``MHEObserver.set_parameter(name, value)``).
        shape : int or (rows, cols)
            Its shape.
        value : array_like, optional
            A fixed value (it can still be changed per step); without one, a value must be set
            before the first window is solved.

        Returns
        -------
        casadi.SX
        """
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError("add_parameter(name)", "an identifier", repr(name))
        if any(name == q[0] for q in self.params):
            raise ModelError("add_parameter(name)", "a name not used by another parameter", repr(name))
        shp = (int(shape), 1) if np.ndim(shape) == 0 else tuple(int(d) for d in shape)
        if len(shp) != 2 or min(shp) < 1:
            raise ModelError(f"add_parameter({name!r}) shape", "a positive int or (rows, cols)", repr(shape))
        sym = self._ca.SX.sym(name, *shp)
        val = None if value is None else _param_value(name, value, shp)
        self.params.append((name, sym, shp, val))
        return sym

    def add_cost(self, expr) -> None:
        """Add a term to the cost of eq. (10) (checked at construction; see the Notes of the class).

        Parameters
        ----------
        expr : casadi.SX
            A scalar expression of the attributes' symbols and the added parameters.
        """
        expr = self._ca.SX(expr)
        if expr.numel() != 1:
            raise ModelError("add_cost(expr)", "a scalar expression", f"shape {expr.shape}")
        self.costs.append(expr)

    def add_constraint(self, expr, lo=None, hi=None) -> None:
        """Add ``lo <= expr <= hi`` (elementwise; ``expr`` affine, checked at construction).

        ``expr`` may also be a CasADi comparison, ``a <= b``, ``a >= b`` or ``a == b``, without
        ``lo`` and ``hi``.

        Parameters
        ----------
        expr : casadi.SX
            An expression affine in the decision variables, the inputs and the added parameters.
        lo, hi : float or array, optional
            Bounds (``None``: unbounded on that side).
        """
        ca = self._ca
        expr = ca.SX(expr)
        if lo is None and hi is None:
            parts, los, his = [], [], []
            for i in range(expr.numel()):
                e = expr[i]
                if e.is_op(ca.OP_LE) or e.is_op(ca.OP_LT):
                    parts.append(e.dep(0) - e.dep(1)), los.append(-np.inf), his.append(0.0)
                elif e.is_op(ca.OP_EQ):
                    parts.append(e.dep(0) - e.dep(1)), los.append(0.0), his.append(0.0)
                else:
                    raise ModelError("add_constraint(expr)", "a comparison (a <= b, a >= b, a == b) or lo / hi bounds",
                                     str(e)[:80])
            self.rows.append((ca.vertcat(*parts), np.array(los), np.array(his)))
            return
        k = expr.numel()
        lo_a = np.broadcast_to(np.asarray(-np.inf if lo is None else lo, dtype=float), (k,)).copy()
        hi_a = np.broadcast_to(np.asarray(np.inf if hi is None else hi, dtype=float), (k,)).copy()
        if np.any(np.isnan(lo_a)) or np.any(np.isnan(hi_a)) or np.any(lo_a > hi_a):
            raise ModelError("add_constraint(lo, hi)", "bounds with lo <= hi (no NaN)", f"{lo_a.tolist()}, {hi_a.tolist()}")
        self.rows.append((ca.reshape(expr, k, 1), lo_a, hi_a))


def _param_value(name: str, value, shape: tuple[int, int]) -> np.ndarray:
    """A parameter's value as CasADi stacks it (``vec``: column-major), checked."""
    arr = np.asarray(value, dtype=float)
    if arr.size != shape[0] * shape[1]:
        raise ModelError(f"parameter {name!r}", f"{shape[0] * shape[1]} values (shape {shape})", f"{arr.size} values")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"parameter {name!r}", "finite values", f"{arr.reshape(-1).tolist()}")
    return arr.reshape(-1, order="F") if arr.ndim == 2 else arr.reshape(-1)


@dataclass(frozen=True, eq=False)
class ExtensionData:
    """What an extension added, in numpy (for :class:`~hybobs_opt.mhe.window.WindowModel`).

    Parameters
    ----------
    residual : slice or None
        Norm 2: the rows of the stacked residual written from the extension's cost.
    cost_vector : (nv,) array or None
        Norms 1 / inf: the extension's linear cost on ``v``.
    rows : slice
        The extension's rows in the MLD encoding (after the MLD rows).
    names : tuple of str
        Parameter names, in the order of ``P``.
    offsets : tuple of slice
        Position of each parameter in ``P``.
    defaults : tuple
        Fixed values (``None`` when the value is set per step).
    cost_constant : callable or None
        Norms 1 / inf: ``(U, Y, x_bar, P) -> J_ext(0, p)``, the term's value at ``v = 0`` (so
        that ``cost_vector @ v + cost_constant(...)`` is the term as written).
    """

    residual: slice | None
    cost_vector: np.ndarray | None
    rows: slice
    names: tuple[str, ...]
    offsets: tuple[slice, ...]
    defaults: tuple
    cost_constant: Callable | None = None

    @property
    def has_cost(self) -> bool:
        return self.residual is not None or self.cost_vector is not None


class MHEFormulation:
    """Eq. (10) of paper 002 (with its 1- / inf-norm variants) in CasADi SX, and its extracted matrices.

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1) with bounded ``X`` and ``U`` (eq. 2).
    T : int
        Window length.
    norm : {"2", "1", "inf"}
        Norm of the cost.
    Wy : (p, p) array
        Output weight.
    Ww, Wa : (n, n) arrays or None
        Disturbance and arrival weights.
    big_m : BigMConstants, optional
        Precomputed constants.
    extend : callable, optional
        ``extend(ext)`` with an :class:`MHEExtension`.

    Attributes
    ----------
    v : casadi.SX
        The MLD decision vector (scaled, layout of :class:`~hybobs_opt.mhe.mld.MLDEncoding`).
    e : casadi.SX
        The epigraph variables (norms 1 / inf; empty for norm 2).
    z : casadi.SX
        ``[v; e]``: the decision vector of the backends.
    U, Y, x_bar, P : casadi.SX
        The parameters (stacked inputs and outputs, arrival prior, extension parameters).
    params : casadi.SX
        ``[U; Y; x_bar; P]``.
    mld_rows, mld_lo, mld_hi : casadi.SX, arrays
        MLD and extension rows ``mld_lo <= mld_rows(v, U, P) <= mld_hi`` (before normalisation).
    epigraph_rows : casadi.SX
        Norms 1 / inf: ``[r / j_s - E e; -r / j_s - E e] <= 0``.
    residual : casadi.SX
        The stacked weighted residual (norm 2: with the extension's rows).
    cost : casadi.SX
        The objective: norm 2, ``||r_base||^2 + J_ext`` (``J_ext`` as the user wrote it); norms
        1 / inf, ``sum(e) + J_ext``.
    enc : MLDEncoding
        The extracted, normalised rows (``A = jacobian(mld_rows, v) / norm``, ...).
    res : StackedResidual
        The extracted residual ``R = jacobian(residual, v)``, ...
    hessian, grad_params, grad0 : arrays
        Norm 2: ``hessian(cost, v)`` and the linear term ``gradient(cost, v)`` at ``v = 0``, as the
        affine map ``grad_params @ p + grad0``.
    lp_c, lp_A, epi_params, epi0 : arrays
        Norms 1 / inf: the cost vector ``jacobian(cost, z)``, the rows ``[enc.A, 0; jacobian(
        epigraph_rows, z)]`` and the epigraph rows' bound ``-(epi_params @ p + epi0)``.
    js : float
        Norms 1 / inf: the residual scale ``j_s`` of the epigraph rows (largest ``|R|``).
    extension : ExtensionData or None

    See Also
    --------
    encode_mld : The MLD constraints it writes.
    MHEObserver : Builds one (``obs.formulation``).
    MHEExtension : Terms added by the user.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import MHEFormulation
    >>> form = MHEFormulation(plant, 3, "2", np.eye(1), None, None)
    >>> form.enc.n_vars, form.enc.n_constraints
    (30, 99)
    >>> MHEObserver(plant, 3).formulation.T
    3
    """

    def __init__(self, system: PWASystem, T: int, norm: str, Wy: np.ndarray, Ww: np.ndarray | None,
                 Wa: np.ndarray | None, *, big_m: BigMConstants | None = None,
                 extend: Callable[[MHEExtension], Any] | None = None):
        ca = _ca()
        T = int(T)
        n, m, p, s = system.n, system.m, system.p, system.n_modes
        self.system, self.T, self.norm = system, T, norm
        disturbances = Ww is not None and T > 1
        sym = mld_expressions(system, T, disturbances=disturbances, big_m=big_m)
        self.symbols = sym
        v, U = sym.v, sym.U
        Y = ca.SX.sym("Y", T * p)
        xbar = ca.SX.sym("x_bar", n)
        self.v, self.U, self.Y, self.x_bar = v, U, Y, xbar
        nv = v.numel()

        # the stacked weighted residual of eq. (10) and the optional terms (residual.py's blocks)
        parts, blocks, row = [], [], 0
        for k in range(T):
            parts.append(ca.mtimes(ca.DM(Wy), Y[k * p:(k + 1) * p] - sym.y_hat[k]))
        blocks.append(("output", slice(0, T * p)))
        row = T * p
        if disturbances:
            for k in range(T - 1):
                parts.append(ca.mtimes(ca.DM(Ww), sym.w[k]))
            blocks.append(("disturbance", slice(row, row + (T - 1) * n)))
            row += (T - 1) * n
        if Wa is not None:
            parts.append(ca.mtimes(ca.DM(Wa), sym.x[0] - xbar))
            blocks.append(("arrival", slice(row, row + n)))
            row += n
        r_base = ca.vertcat(*parts)

        # the extension
        ext = None
        if extend is not None:
            if not callable(extend):
                raise ModelError("extend", "a callable extend(ext) receiving an MHEExtension", type(extend).__name__)
            ext = MHEExtension(sym, norm, U, Y, xbar, (T, n, m, p, s))
            extend(ext)
        ext_params = [] if ext is None else ext.params
        P = ca.vertcat(*[ca.vec(q[1]) for q in ext_params]) if ext_params else ca.SX.sym("P", 0)
        self.P = P
        params = ca.vertcat(U, Y, xbar, P)
        self.params = params
        npar = params.numel()
        n_u, n_y = U.numel(), Y.numel()
        self._param_split = (n_u, n_u + n_y, n_u + n_y + n)

        ext_rows = (ca.SX(0, 1), np.zeros(0), np.zeros(0))
        if ext is not None and ext.rows:
            exprs = [r[0] for r in ext.rows]
            for i, e in enumerate(exprs):
                self._check_symbols(e, f"add_constraint #{i}")
                if ca.depends_on(e, ca.vertcat(Y, xbar)):
                    raise ModelError(f"add_constraint #{i}", "an expression of the decision variables, the inputs u and "
                                     "the extension's parameters (not of the data y or x_bar)", "depends on y or x_bar")
                if not _is_affine(e, ca.vertcat(v, params)):
                    raise ModelError(f"add_constraint #{i}", "an affine expression of the decision variables and "
                                     "parameters (a linear constraint)", "a nonlinear expression")
            ext_rows = (ca.vertcat(*exprs), np.concatenate([r[1] for r in ext.rows]),
                        np.concatenate([r[2] for r in ext.rows]))
        n_mld = sym.rows.numel()
        self.mld_rows = ca.vertcat(sym.rows, ext_rows[0])
        self.mld_lo = np.concatenate([sym.lo, ext_rows[1]])
        self.mld_hi = np.concatenate([sym.hi, ext_rows[2]])
        self.enc: MLDEncoding = mld_encoding(sym, system, T, extra_rows=ext_rows, params=P)

        J_ext = ca.SX(0)
        if ext is not None:
            for i, c in enumerate(ext.costs):
                self._check_symbols(c, f"add_cost #{i}")
                J_ext = J_ext + c
        has_cost = ext is not None and bool(ext.costs)
        residual, res_ext, cost_vec = r_base, None, None
        if norm == "2" and has_cost:
            rows_ext = self._sum_of_squares(J_ext, v, params)
            residual = ca.vertcat(r_base, rows_ext)
            res_ext = slice(row, row + rows_ext.numel())
            blocks.append(("extension", res_ext))
        self.residual = residual
        R, Sp, r0 = affine_parts(residual, v, params)
        a, b, c = self._param_split
        self.res = StackedResidual(R, Sp[:, a:b], Sp[:, :a], Sp[:, b:c], r0, tuple(blocks), SP=Sp[:, c:])

        if norm == "2":
            self.e = ca.SX.sym("e", 0)
            self.z = v
            self.epigraph_rows = ca.SX(0, 1)
            self.cost = ca.sumsqr(r_base) + J_ext
            grad = ca.gradient(self.cost, v)
            F = ca.Function("mhe_cost", [v, params], [ca.hessian(self.cost, v)[0], ca.jacobian(grad, params), grad])
            H, Gp, g0 = F(np.zeros(nv), np.zeros(npar))
            self.hessian = np.array(H.full(), dtype=float)
            self.grad_params = np.array(Gp.full(), dtype=float)
            self.grad0 = np.array(g0.full(), dtype=float).reshape(-1)
            self.js = None
        else:
            Rb = R[: r_base.numel()]
            js = float(np.max(np.abs(Rb))) or 1.0
            self.js = js
            nr = r_base.numel()
            if norm == "1":
                ns = nr
                E = np.eye(nr)
            else:
                ns = len([bk for bk in blocks if bk[0] != "extension"])
                E = np.zeros((nr, ns))
                for bi, (_, sl) in enumerate(blocks):
                    E[sl, bi] = 1.0
            e = ca.SX.sym("e", ns)
            self.e, self.z = e, ca.vertcat(v, e)
            Ee = ca.mtimes(ca.DM(E), e)
            self.epigraph_rows = ca.vertcat(r_base / js - Ee, -r_base / js - Ee)
            self.cost = ca.sum1(e) + J_ext
            if has_cost:
                if not _is_affine(J_ext, ca.vertcat(v, params)) or ca.depends_on(ca.jacobian(J_ext, v), params):
                    raise ModelError("add_cost", f"a linear term with constant coefficients for norm {norm!r} (a MILP)",
                                     "a nonlinear term or coefficients depending on the parameters")
            F = ca.Function("mhe_lp", [self.z, params], [ca.jacobian(self.cost, self.z)])
            c_lp = np.array(F(np.zeros(nv + ns), np.zeros(npar)).full(), dtype=float).reshape(-1)
            if has_cost:
                cost_vec = c_lp[:nv].copy()
                const_fn = ca.Function("ext_cost_constant", [params], [ca.substitute(J_ext, v, ca.DM.zeros(nv))])
                zero_v = np.zeros(0)

                def cost_constant(U_, Y_, xbar_, P_, _f=const_fn, _pv=self.parameter_vector):
                    return float(_f(_pv(U_, Y_, xbar_, P_ if P_ is not None else zero_v)))
            Aepi, Pepi, c0 = affine_parts(self.epigraph_rows, self.z, params)
            self.lp_c = c_lp
            self.lp_A = np.vstack([np.hstack([self.enc.A, np.zeros((self.enc.n_constraints, ns))]), Aepi])
            self.epi_params, self.epi0 = Pepi, c0
            self.lp_lb = np.concatenate([self.enc.lb, np.zeros(ns)])
            self.lp_ub = np.concatenate([self.enc.ub, np.full(ns, np.inf)])
            self.lp_discrete = np.concatenate([self.enc.discrete, np.zeros(ns, dtype=bool)])
            self.nslack = ns
        self.extension = None
        if not (norm != "2" and has_cost):
            cost_constant = None
        if ext is not None:
            offs, o = [], 0
            for _, _, shp, _ in ext_params:
                offs.append(slice(o, o + shp[0] * shp[1]))
                o += shp[0] * shp[1]
            self.extension = ExtensionData(res_ext, cost_vec, slice(n_mld, self.enc.n_constraints),
                                           tuple(q[0] for q in ext_params), tuple(offs),
                                           tuple(q[3] for q in ext_params), cost_constant)

    # ------------------------------------------------------------------ checks
    def _check_symbols(self, expr, what: str) -> None:
        ca = _ca()
        allowed = ca.vertcat(self.v, self.U, self.Y, self.x_bar, *([self.P] if self.P.numel() else []))
        try:
            ca.Function("check", [allowed], [expr])
        except RuntimeError as exc:
            raise ModelError(what, "an expression of the window's symbols (ext.x, ext.u, ...) and the added parameters",
                             f"free symbols ({str(exc).splitlines()[0][:120]})") from None

    def _sum_of_squares(self, J, v, params):
        """Rows ``L' v + m(p)`` with ``||L' v + m(p)||^2 = J(v, p) - c(p)``: the norm-2 extension cost as a residual.

        ``H = hessian(J, v)`` must be constant (J quadratic) and positive semidefinite (convex),
        the gradient at ``v = 0`` affine in ``p`` and in the range of ``H`` (else ``J`` is
        unbounded below along a direction of zero curvature, or needs a linear term that no sum
        of squares has).
        """
        ca = _ca()
        allp = ca.vertcat(v, params)
        H_sx = ca.hessian(J, v)[0]
        if ca.depends_on(H_sx, allp):
            raise ModelError("add_cost", "a quadratic term for norm '2' (its Hessian in the decision variables must be "
                             "constant)", "a non-quadratic expression or coefficients depending on the parameters")
        grad = ca.gradient(J, v)
        if ca.depends_on(ca.jacobian(grad, allp), allp):
            raise ModelError("add_cost", "a quadratic term whose linear part is affine in the parameters",
                             "the gradient is not affine in the parameters")
        F = ca.Function("ext_cost", [v, params], [H_sx, ca.jacobian(grad, params), grad])
        H, Gp, g0 = (np.array(M.full(), dtype=float) for M in F(np.zeros(v.numel()), np.zeros(params.numel())))
        H = 0.5 * (H + H.T)
        lam, V = np.linalg.eigh(H)
        scale = max(float(np.max(np.abs(lam), initial=0.0)), 1e-300)
        if lam.size and lam.min() < -MHE_EXTENSION_PSD_RTOL * scale:
            raise ModelError("add_cost", "a convex quadratic (positive semidefinite Hessian)",
                             f"smallest Hessian eigenvalue {lam.min():.3g} (largest {scale:.3g})")
        keep = lam > MHE_EXTENSION_PSD_RTOL * scale
        if not keep.any():
            raise ModelError("add_cost", "a quadratic term with curvature for norm '2' (a sum of squares)",
                             "a term without quadratic part")
        Vk, lk = V[:, keep], lam[keep]
        G = np.hstack([Gp, g0.reshape(-1, 1)])
        out_of_range = G - Vk @ (Vk.T @ G)
        gscale = max(float(np.max(np.abs(G), initial=0.0)), 1.0)
        if np.max(np.abs(out_of_range), initial=0.0) > MHE_EXTENSION_RANGE_RTOL * gscale:
            raise ModelError("add_cost", "a sum of squares: the linear part must lie in the range of the Hessian",
                             "a linear term along a direction of zero curvature")
        # J = 0.5 v'Hv + g(p)'v + c(p) = ||L'v + m(p)||^2 + c'(p), L = V sqrt(lam / 2), m = 0.5 L^+ g
        d = np.sqrt(0.5 * lk)
        Lt = (Vk * d).T
        Mg = 0.5 * (Vk / d).T
        return (ca.mtimes(ca.DM(Lt), v) + ca.mtimes(ca.DM(Mg @ Gp), params) + ca.DM(Mg @ g0))

    # ------------------------------------------------------------------ per step (numpy only)
    def parameter_vector(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, P: np.ndarray | None = None) -> np.ndarray:
        """``p = [U; Y; x_bar; P]`` of one window.

        Parameters
        ----------
        U : (T, m) or (T m,) array
        Y : (T, p) or (T p,) array
        xbar : (n,) array
        P : (n_P,) array, optional
            The extension's parameters (none without an extension).

        Returns
        -------
        ndarray
            ``p = [U; Y; x_bar; P]`` of one window.
        """
        parts = [np.asarray(U, dtype=float).reshape(-1), np.asarray(Y, dtype=float).reshape(-1),
                 np.asarray(xbar, dtype=float).reshape(-1)]
        if self.P.numel():
            parts.append(np.asarray(P, dtype=float).reshape(-1))
        return np.concatenate(parts)

    def linear_term(self, p: np.ndarray) -> np.ndarray:
        """Norm 2: ``gradient(cost, v)`` at ``v = 0`` for the parameters ``p`` (``grad_params @ p + grad0``).

        Returns
        -------
        ndarray
            Norm 2: ``gradient(cost, v)`` at ``v = 0`` for the parameters ``p``
            (``grad_params @ p + grad0``).
        """
        return self.grad_params @ p + self.grad0

    def epigraph_upper(self, p: np.ndarray) -> np.ndarray:
        """Norms 1 / inf: the epigraph rows' upper bounds ``-(epi_params @ p + epi0)`` (lower: ``-inf``).

        Returns
        -------
        ndarray
            Norms 1 / inf: the epigraph rows' upper bounds ``-(epi_params @ p + epi0)`` (lower:
            ``-inf``).
        """
        return -(self.epi_params @ p + self.epi0)


def _is_affine(expr, x) -> bool:
    """Whether ``expr`` is affine in the symbols ``x`` (its Jacobian does not depend on them)."""
    ca = _ca()
    return not ca.depends_on(ca.jacobian(expr, x), x)
