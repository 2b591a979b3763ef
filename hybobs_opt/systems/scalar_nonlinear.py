"""Nonlinear systems built from scalar functions of linear state combinations (paper 004, eqs. 1-3).

The class of Rajamani et al. (paper 004, Section 2) is

.. math::

    \\dot x = A x + F f(x) + g(y, u), \\qquad y = h(C x),

    f(x) = [f_1(E_1 x), \\dots, f_r(E_r x)]^T, \\qquad h(Cx) = [h_1(C_1 x), \\dots, h_m(C_m x)]^T,

where every :math:`f_i` and :math:`h_j` is a scalar function of one scalar argument.  Eq. (1) of
the paper has no linear term; the linear part ``A x`` is added here because the paper's own
special cases use it (Corollary 1.1: ``Ff(x) = Ax``; the piston model, eq. (63):
``x' = Ax + Bu``).  A linear term could be folded into ``F f`` with identity ``f_i``, but keeping
it apart keeps the Jacobian-bound data (``U``, ``V`` of eq. (5)) free of trivial entries.
``g(y, u)`` is split into a linear input term ``B u`` and an optional general callable
``g(y, u)``; both are known signals for an observer (they cancel in the error dynamics, eq. (7)).

The Jacobian bounds (4)-(5), monotonicity and the observer LMIs are built elsewhere (``lmi``);
this module provides what they need: the argument ranges of every ``E_i x`` and ``C_j x`` over the
operating box, and vectorised values and derivatives of every scalar function.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from ..defaults import FUNCTION_CHECK_SAMPLES
from ..errors import ModelError
from ..geometry.lp import row_range
from ..tolerances import DERIVATIVE_CHECK_RTOL
from ._model_io import ModelDictMixin
from .._validate import as_matrix, as_names, as_text, names_or_default, probe_callable
from ..geometry.polytope import Polytope


GFn = Callable[[np.ndarray, np.ndarray], np.ndarray]
SXMap = Callable[[ca.SX], ca.SX]


def _to_scalar_sx(value, z: ca.SX, field_name: str) -> ca.SX:
    """Check that ``value`` is a 1x1 SX expression of the symbol ``z`` only."""
    if isinstance(value, ca.MX):
        raise ModelError(field_name, "an SX expression (CasADi SX, not MX)", "an MX expression")
    try:
        out = ca.SX(value)
    except Exception as exc:  # casadi raises NotImplementedError/TypeError for foreign objects
        raise ModelError(field_name, "a CasADi SX scalar expression", f"{type(value).__name__} ({exc})") from None
    if out.shape != (1, 1):
        raise ModelError(field_name, "a scalar (1x1) expression", f"shape {out.shape}")
    for s in ca.symvar(out):
        if not ca.is_equal(s, z):
            raise ModelError(field_name, "an expression of its argument only", f"a free symbol {s}")
    # math.sin(SX) and float(SX) silently give a constant NaN: catch it here, not on the box.
    if out.is_constant() and not np.isfinite(float(out)):
        raise ModelError(field_name, "a symbolic expression built with casadi functions (ca.sin, not math.sin)",
                         f"the constant {float(out)}")
    return out


@dataclass(frozen=True, eq=False)
class ScalarFunction:
    """A scalar function of one scalar argument, ``f_i`` or ``h_j`` of eq. (3), paper 004.

    Parameters
    ----------
    name : str
        Label used in error messages and reports (``"V cos(psi)"``, ``"sensor 1"``).
    expr : callable
        ``expr(z) -> SX`` mapping a CasADi ``SX`` scalar to an ``SX`` expression (use ``casadi``
        functions: ``ca.cos``, ``ca.tan``, ...), so the function is available symbolically.
    derivative : callable, optional
        ``derivative(z) -> SX``, the exact derivative ``df/dz``.  If omitted it is computed by
        CasADi automatic differentiation of ``expr``.  A supplied derivative is checked against
        automatic differentiation on the operating box by :class:`ScalarNonlinearSystem`.

    See Also
    --------
    ScalarNonlinearSystem : uses them as ``f_i`` and ``h_j``.

    Notes
    -----
    The CasADi functions are built once, here; :meth:`value` and :meth:`deriv` evaluate them on
    numpy arrays of any shape (CasADi maps a scalar function over a row of arguments).

    Examples
    --------
    >>> import casadi as ca, numpy as np
    >>> from hybobs_opt.systems import ScalarFunction
    >>> cosine = ScalarFunction("cos", ca.cos)             # derivative by automatic differentiation
    >>> float(cosine.value(0.0)), float(cosine.deriv(np.pi / 2))
    (1.0, -1.0)
    """

    name: str
    expr: SXMap
    derivative: SXMap | None = None
    _z: ca.SX = field(init=False, repr=False)
    _value_sx: ca.SX = field(init=False, repr=False)
    _deriv_sx: ca.SX = field(init=False, repr=False)
    _value_fn: ca.Function = field(init=False, repr=False)
    _deriv_fn: ca.Function = field(init=False, repr=False)
    _autodiff_fn: ca.Function = field(init=False, repr=False)

    def __post_init__(self) -> None:
        as_text(self.name, "ScalarFunction.name")
        label = f"ScalarFunction {self.name!r}"
        if not callable(self.expr):
            raise ModelError(f"{label}.expr", "a callable expr(z: SX) -> SX", type(self.expr).__name__)
        if self.derivative is not None and not callable(self.derivative):
            raise ModelError(f"{label}.derivative", "a callable derivative(z: SX) -> SX or None", type(self.derivative).__name__)
        z = ca.SX.sym("z")
        try:
            raw = self.expr(z)
        except Exception as exc:
            raise ModelError(f"{label}.expr", "a callable mapping a CasADi SX scalar to an SX expression",
                             f"{type(exc).__name__}: {exc}") from None
        value = _to_scalar_sx(raw, z, f"{label}.expr")
        autodiff = ca.jacobian(value, z)
        if self.derivative is None:
            deriv = autodiff
        else:
            try:
                raw_d = self.derivative(z)
            except Exception as exc:
                raise ModelError(f"{label}.derivative", "a callable mapping a CasADi SX scalar to an SX expression",
                                 f"{type(exc).__name__}: {exc}") from None
            deriv = _to_scalar_sx(raw_d, z, f"{label}.derivative")
        # CasADi function names: a letter, then ASCII letters, digits and single underscores (a
        # name such as "é" or "x²" would make CasADi raise a RuntimeError).
        safe = "_".join("".join(c if c.isascii() and c.isalnum() else " " for c in self.name).split()) or "fn"
        object.__setattr__(self, "_z", z)
        object.__setattr__(self, "_value_sx", value)
        object.__setattr__(self, "_deriv_sx", deriv)
        object.__setattr__(self, "_value_fn", ca.Function(f"f_{safe}", [z], [value]))
        object.__setattr__(self, "_deriv_fn", ca.Function(f"df_{safe}", [z], [deriv]))
        object.__setattr__(self, "_autodiff_fn", ca.Function(f"adf_{safe}", [z], [autodiff]))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def identity(cls, name: str = "identity") -> "ScalarFunction":
        """``h(z) = z`` (a linear output, ``M_j = N_j = 1`` in eq. (4)).

        Parameters
        ----------
        name : str, default "identity"
            Label of the function.

        Returns
        -------
        ScalarFunction
            The identity, with derivative 1.
        """
        return cls(name, lambda z: z, lambda z: ca.SX(1.0))

    @classmethod
    def from_text(cls, name: str, expr: str, derivative: str | None = None, variable: str = "z",
                  field: str | None = None) -> "ScalarFunction":
        """A function written as text over ``variable`` (``"V*cos(z)"``), as model files hold it.

        The text is parsed by :func:`hybobs_opt.systems.expressions.parse_expression` (no Python is
        evaluated); ``field`` names the entry in errors (default ``"ScalarFunction NAME"``).

        Parameters
        ----------
        name : str
            Label of the function.
        expr : str
            The function's text, e.g. ``"V*cos(z)"``.
        derivative : str, optional
            Text of the exact derivative; ``None`` uses automatic differentiation of ``expr``.
        variable : str, default "z"
            Name of the argument in ``expr`` and ``derivative`` (an identifier).
        field : str, optional
            Name of the entry in error messages.

        Returns
        -------
        ScalarFunction
            The parsed function (text checked by :func:`~hybobs_opt.systems.parse_expression`).

        Raises
        ------
        ModelError
            If ``variable`` is not an identifier or a text does not parse.
        """
        from .expressions import parse_expression

        label = field or f"ScalarFunction {name!r}"
        as_text(variable, f"{label}.variable")
        if not variable.isidentifier():
            raise ModelError(f"{label}.variable", "a variable name that is an identifier (letters, digits, _)", repr(variable))
        parse_expression(expr, {variable: ca.SX.sym(variable)}, f"{label}.expr")  # errors name the entry now
        if derivative is not None:
            parse_expression(derivative, {variable: ca.SX.sym(variable)}, f"{label}.derivative")
        d = None if derivative is None else (lambda z: parse_expression(derivative, {variable: z}, f"{label}.derivative"))
        return cls(name, lambda z: parse_expression(expr, {variable: z}, f"{label}.expr"), d)

    # ------------------------------------------------------------------ numeric evaluation
    @staticmethod
    def _eval(fn: ca.Function, z) -> np.ndarray:
        zz = np.asarray(z, dtype=float)
        if zz.size == 0:
            return np.zeros(zz.shape)
        out = np.asarray(fn(zz.reshape(1, -1)), dtype=float).reshape(zz.shape)
        return out

    def value(self, z) -> np.ndarray:
        """``f(z)`` elementwise for an array ``z`` of any shape (same shape out).

        Parameters
        ----------
        z : array_like
            Arguments, any shape.

        Returns
        -------
        ndarray
            ``f(z)``, shaped like ``z``.
        """
        return self._eval(self._value_fn, z)

    __call__ = value

    def deriv(self, z) -> np.ndarray:
        """``f'(z)`` elementwise: the supplied derivative, else CasADi automatic differentiation.

        Parameters
        ----------
        z : array_like
            Arguments, any shape (same shape out).

        Returns
        -------
        ndarray
            ``f'(z)``, shaped like ``z``.
        """
        return self._eval(self._deriv_fn, z)

    def deriv_autodiff(self, z) -> np.ndarray:
        """``f'(z)`` by CasADi automatic differentiation of ``expr``, whatever ``derivative`` says.

        Parameters
        ----------
        z : array_like
            Arguments, any shape (same shape out).

        Returns
        -------
        ndarray
            ``f'(z)``, shaped like ``z``.
        """
        return self._eval(self._autodiff_fn, z)

    # ------------------------------------------------------------------ symbolic evaluation
    def sx(self, z: ca.SX) -> ca.SX:
        """Symbolic value at an SX scalar ``z``.

        Parameters
        ----------
        z : casadi.SX
            Symbolic scalar argument.

        Returns
        -------
        casadi.SX
            ``f(z)``.
        """
        return ca.substitute(self._value_sx, self._z, z)

    def sx_deriv(self, z: ca.SX) -> ca.SX:
        """Symbolic derivative at an SX scalar ``z``.

        Parameters
        ----------
        z : casadi.SX
            Symbolic scalar argument.

        Returns
        -------
        casadi.SX
            ``f'(z)``.
        """
        return ca.substitute(self._deriv_sx, self._z, z)

    @property
    def has_user_derivative(self) -> bool:
        return self.derivative is not None

    @cached_property
    def is_identity(self) -> bool:
        """True when the expression simplifies to its argument (a linear output ``y_j = C_j x``)."""
        return bool(ca.is_equal(ca.simplify(self._value_sx), self._z, 10))


@dataclass(frozen=True, eq=False, kw_only=True)
class ScalarNonlinearSystem(ModelDictMixin):
    """Continuous-time system of eqs. (1)-(3), paper 004, on a bounded operating box.

    ``x' = A x + F f(E x) + B u + g(y, u)``, ``y_j = h_j(C_j x)``.

    Parameters
    ----------
    box : Polytope
        Bounded operating region over ``x`` (dimension ``n``; ``Polytope.from_box`` for a box).
        It fixes ``n`` and the argument intervals on which the functions are checked and on
        which the Jacobian bounds (4)-(5) are to be computed.
    C : (m, n) array
        Output rows ``C_j`` (eq. 3); row ``j`` is the argument of ``h_j``.
    h : sequence of ScalarFunction or None, optional
        ``h_1 ... h_m``; ``None`` (or a ``None`` entry) means the identity (a linear output).
    A : (n, n) array, optional
        Linear part (zeros by default; paper 004 writes it only in Corollary 1.1 and eq. (63)).
    F : (n, r) array, optional
        Mixing matrix of the nonlinear terms (eq. 1).  Required when ``f`` is not empty.
    E : (r, n) array, optional
        Row ``i`` is ``E_i``, the state combination ``f_i`` acts on (eq. 3).
    f : sequence of ScalarFunction
        ``f_1 ... f_r``.
    B : (n, k) array, optional
        Linear input term; ``k`` is the number of inputs (0 by default).
    g : callable, optional
        ``g(y, u) -> (n,)`` extra known term of eq. (1) (numeric only).
    state_names, input_names, output_names : sequence of str
        Defaults ``x1..``, ``u1..``, ``y1..``; the state names default to the box's names when
        the box was built with names.
    name : str
        Label of the system.

    See Also
    --------
    ScalarFunction : its scalar nonlinearities.
    hybobs_opt.sim.simulate_nonlinear : simulates it.
    hybobs_opt.lmi.jacobian_bounds : the Jacobian bounds of its observer LMIs.

    Notes
    -----
    Validation: shapes and finiteness of every matrix; the box bounded and non-empty; every
    ``f_i``/``h_j`` and its derivative finite on :data:`~hybobs_opt.defaults.FUNCTION_CHECK_SAMPLES` points of its
    argument interval over the box; a supplied derivative equal to the automatic one there (to
    :data:`~hybobs_opt.tolerances.DERIVATIVE_CHECK_RTOL`); ``g`` returning a finite ``(n,)``
    vector at the centre of the box.

    Examples
    --------
    The tracked vehicle of paper 004 (eqs. 56-59): ``X' = V cos(psi)``, ``Y' = V sin(psi)``, ...

    >>> from hybobs_opt import get_example
    >>> vehicle = get_example("vehicle_tracking").build()
    >>> vehicle.n, vehicle.m, vehicle.p, [f.name for f in vehicle.f]
    (4, 1, 2, ['V cos(psi)', 'V sin(psi)', 'V/(l_f+l_r) tan(delta_f)'])
    >>> vehicle.F.shape, vehicle.E.shape                  # x' = A x + F f(E x) + B u
    ((4, 3), (3, 4))
    """

    box: Polytope
    C: np.ndarray
    h: tuple[ScalarFunction | None, ...] | None = None
    A: np.ndarray | None = None
    F: np.ndarray | None = None
    E: np.ndarray | None = None
    f: tuple[ScalarFunction, ...] = ()
    B: np.ndarray | None = None
    g: GFn | None = None
    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    name: str = "scalar_nonlinear"
    box_lower: np.ndarray = field(init=False, repr=False)
    box_upper: np.ndarray = field(init=False, repr=False)
    f_ranges: np.ndarray = field(init=False, repr=False)
    h_ranges: np.ndarray = field(init=False, repr=False)
    _dyn_fn: ca.Function = field(init=False, repr=False)
    _out_fn: ca.Function = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.box, Polytope):
            raise ModelError("box", "a bounded Polytope over x", type(self.box).__name__)
        n = self.box.dim
        try:
            lo, hi = self.box.bounding_box()
        except ModelError as exc:
            raise ModelError("box", "a bounded, non-empty Polytope over x", str(exc)) from None
        for arr in (lo, hi):
            arr.setflags(write=False)

        as_text(self.name, "name")
        C = as_matrix(self.C, "C", (None, n))
        m_out = C.shape[0]
        if m_out == 0:
            raise ModelError("C", "at least one output row", f"shape {C.shape}")
        h = self._functions(self.h, "h", m_out, allow_identity=True)
        f = self._functions(self.f, "f", None, allow_identity=False)
        r = len(f)
        A = as_matrix(np.zeros((n, n)) if self.A is None else self.A, "A", (n, n))
        if r and (self.F is None or self.E is None):
            raise ModelError("F" if self.F is None else "E", f"a matrix for the {r} functions f", "None")
        F = as_matrix(np.zeros((n, 0)) if self.F is None else self.F, "F", (n, r))
        E = as_matrix(np.zeros((0, n)) if self.E is None else self.E, "E", (r, n))
        # Without B the input names give the number of inputs; with B an empty B is "no inputs" only.
        given = _name_count(self.input_names, "input_names")
        if self.B is None:
            B = as_matrix(np.zeros((n, given)), "B", (n, given))
        else:
            B = as_matrix(self.B, "B", (n, None))
            if B.shape[1] == 0 and given:
                raise ModelError("B", f"an (n, k) input matrix with a column for each of the {given} input(s)",
                                 f"an empty array of shape {np.shape(self.B)}")
        k = B.shape[1]
        if self.g is not None and not callable(self.g):
            raise ModelError("g", "a callable g(y, u) -> (n,) or None", type(self.g).__name__)

        default_states = self.box.names if not _default_names(self.box.names, "z") else ()
        state_names = as_names(default_states if _no_names(self.state_names) else self.state_names, "state_names", n, "x")
        if not _default_names(self.box.names, "z") and self.box.names != state_names:
            raise ModelError("box.names", f"the state names {state_names} (or no names)", f"{self.box.names}")
        input_names = as_names(self.input_names, "input_names", k, "u")
        output_names = as_names(self.output_names, "output_names", m_out, "y")
        both = sorted(set(state_names) & set(input_names))
        if both:
            raise ModelError("input_names", f"names distinct from the state names {list(state_names)}", f"{both[0]!r} in both")

        f_ranges = _ranges(self.box, E, "E")
        h_ranges = _ranges(self.box, C, "C")
        for i, fn in enumerate(f):
            _check_function(fn, f"f[{i}] ({fn.name})", f_ranges[i])
        for j, fn in enumerate(h):
            _check_function(fn, f"h[{j}] ({fn.name})", h_ranges[j])

        x = ca.SX.sym("x", n)
        z_f = ca.mtimes(ca.DM(E), x)
        f_vec = ca.vertcat(*[fn.sx(z_f[i]) for i, fn in enumerate(f)]) if r else ca.SX.zeros(0, 1)
        dyn = ca.mtimes(ca.DM(A), x) + (ca.mtimes(ca.DM(F), f_vec) if r else ca.SX.zeros(n, 1))
        z_h = ca.mtimes(ca.DM(C), x)
        out = ca.vertcat(*[fn.sx(z_h[j]) for j, fn in enumerate(h)])

        for name, value in (
            ("C", C), ("h", h), ("A", A), ("F", F), ("E", E), ("f", f), ("B", B),
            ("state_names", state_names), ("input_names", input_names), ("output_names", output_names),
            ("box_lower", lo), ("box_upper", hi), ("f_ranges", f_ranges), ("h_ranges", h_ranges),
            ("_dyn_fn", ca.Function("dynamics", [x], [dyn])), ("_out_fn", ca.Function("output", [x], [out])),
        ):
            object.__setattr__(self, name, value)

        if self.g is not None:
            centre = 0.5 * (lo + hi)
            y0 = self.output(centre)
            probe_callable(self.g, (y0, np.zeros(k)), "g", n, "g(y, u) -> (n,)",
                           f"the centre of the box (y = {y0.tolist()}, u = 0)", flat=True)

    @staticmethod
    def _functions(value, label: str, size: int | None, allow_identity: bool) -> tuple[ScalarFunction, ...]:
        if value is None:
            if not allow_identity:
                raise ModelError(label, "a sequence of ScalarFunction", "None")
            return tuple(ScalarFunction.identity() for _ in range(size or 0))
        if isinstance(value, (ScalarFunction, str, bytes)) or not isinstance(value, Sequence):
            raise ModelError(label, "a sequence (tuple/list) of ScalarFunction", type(value).__name__)
        if size is not None and len(value) != size:
            raise ModelError(label, f"{size} functions (one per row of C)", f"{len(value)}")
        out = []
        for i, fn in enumerate(value):
            if fn is None and allow_identity:
                fn = ScalarFunction.identity()
            if not isinstance(fn, ScalarFunction):
                raise ModelError(f"{label}[{i}]", "a ScalarFunction" + (" or None" if allow_identity else ""),
                                 type(fn).__name__)
            out.append(fn)
        return tuple(out)

    # ------------------------------------------------------------------ sizes
    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs (columns of ``B``)."""
        return self.B.shape[1]

    @property
    def p(self) -> int:
        """Number of outputs (``m`` in the paper's notation)."""
        return self.C.shape[0]

    @property
    def r(self) -> int:
        """Number of nonlinear process functions ``f_i``."""
        return len(self.f)

    @property
    def linear_outputs(self) -> tuple[bool, ...]:
        """Per output, whether ``h_j`` is the identity (``M_j = N_j = 1``)."""
        return tuple(fn.is_identity for fn in self.h)

    # ------------------------------------------------------------------ numeric evaluation
    def _states(self, x) -> tuple[np.ndarray, bool]:
        X = np.asarray(x, dtype=float)
        single = X.ndim == 1
        X2 = X.reshape(1, -1) if single else X
        if X2.ndim != 2 or X2.shape[1] != self.n:
            raise ModelError("x", f"a state of length {self.n} or an (N, {self.n}) array", f"shape {X.shape}")
        return X2, single

    def _inputs(self, u, N: int, single: bool) -> np.ndarray:
        if u is None:
            return np.zeros((N, self.m))
        U = np.asarray(u, dtype=float)
        if U.shape == (self.m,):
            return np.broadcast_to(U, (N, self.m))  # one input applied to every state of the batch
        if not single and U.shape == (N, self.m):
            return U
        raise ModelError("u", f"an input of length {self.m}" + ("" if single else f" or an ({N}, {self.m}) array"),
                         f"shape {U.shape}")

    def f_values(self, x) -> np.ndarray:
        """``f_i(E_i x)`` for a state ``(n,)`` -> ``(r,)`` or states ``(N, n)`` -> ``(N, r)``.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(r,)`` or ``(N, r)``.
        """
        X, single = self._states(x)
        Z = X @ self.E.T
        out = np.column_stack([fn.value(Z[:, i]) for i, fn in enumerate(self.f)]) if self.r else np.zeros((X.shape[0], 0))
        return out[0] if single else out

    def f_derivatives(self, x) -> np.ndarray:
        """``f_i'(E_i x)`` (the diagonal of eq. (5)'s Jacobian), shaped like :meth:`f_values`.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(r,)`` or ``(N, r)``.
        """
        X, single = self._states(x)
        Z = X @ self.E.T
        out = np.column_stack([fn.deriv(Z[:, i]) for i, fn in enumerate(self.f)]) if self.r else np.zeros((X.shape[0], 0))
        return out[0] if single else out

    def h_values(self, x) -> np.ndarray:
        """``h_j(C_j x)`` for ``(n,)`` -> ``(m,)`` or ``(N, n)`` -> ``(N, m)``.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(m,)`` or ``(N, m)``.
        """
        X, single = self._states(x)
        Z = X @ self.C.T
        out = np.column_stack([fn.value(Z[:, j]) for j, fn in enumerate(self.h)])
        return out[0] if single else out

    def h_derivatives(self, x) -> np.ndarray:
        """``h_j'(C_j x)`` (the diagonal of eq. (4)'s Jacobian), shaped like :meth:`h_values`.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(m,)`` or ``(N, m)``.
        """
        X, single = self._states(x)
        Z = X @ self.C.T
        out = np.column_stack([fn.deriv(Z[:, j]) for j, fn in enumerate(self.h)])
        return out[0] if single else out

    def output(self, x, u=None) -> np.ndarray:
        """``y = h(C x)`` (eq. 2); ``u`` is accepted for a uniform signature and not used.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s); the result is ``(p,)`` or ``(N, p)``.
        u : array_like, optional
            Ignored.

        Returns
        -------
        ndarray
            ``y``, ``(p,)`` or ``(N, p)``.
        """
        X, single = self._states(x)
        Y = np.asarray(self._out_fn(X.T), dtype=float).reshape(self.p, X.shape[0]).T
        return Y[0] if single else Y

    def rhs(self, x, u=None) -> np.ndarray:
        """``dx/dt = A x + F f(E x) + B u + g(y, u)`` (eq. 1) for one state or ``(N, n)`` states.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s); the result has the same shape.
        u : (k,) or (N, k) array_like, optional
            Input(s); one ``(k,)`` input is applied to every state of a batch; ``None`` means zeros.

        Returns
        -------
        ndarray
            ``dx/dt``, shaped like ``x``.
        """
        X, single = self._states(x)
        U = self._inputs(u, X.shape[0], single)
        dX = np.asarray(self._dyn_fn(X.T), dtype=float).reshape(self.n, X.shape[0]).T + U @ self.B.T
        if self.g is not None:
            Y = self.output(X)
            dX = dX + np.array([np.asarray(self.g(Y[k], U[k]), dtype=float) for k in range(X.shape[0])])
        return dX[0] if single else dX

    def dynamics_jacobian(self, x) -> np.ndarray:
        """``A + F diag(f'(E x)) E`` -> ``(n, n)`` (or ``(N, n, n)``).

        The Jacobian of the state-dependent part of eq. (1); ``g(y, u)`` is a known signal of the
        measured output and input, as in the observer (6), so it is not differentiated.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(n, n)`` or ``(N, n, n)``.
        """
        D = self.f_derivatives(x)
        J = self.A + np.einsum("ir,...r,rj->...ij", self.F, D, self.E)
        return J

    def output_jacobian(self, x) -> np.ndarray:
        """``diag(h'(C x)) C`` -> ``(m, n)`` (or ``(N, m, n)``), the matrix of eq. (10).

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            ``(m, n)`` or ``(N, m, n)``.
        """
        D = self.h_derivatives(x)
        return D[..., :, None] * self.C

    # ------------------------------------------------------------------ symbolic evaluation
    def sx_dynamics(self, x: ca.SX) -> ca.SX:
        """``A x + F f(E x)`` as an SX expression of an SX state ``x`` (no ``B u``, no ``g``).

        Parameters
        ----------
        x : casadi.SX
            Symbolic state, ``(n, 1)``.

        Returns
        -------
        casadi.SX
            ``(n,)`` expression.
        """
        return self._dyn_fn(x)

    def sx_output(self, x: ca.SX) -> ca.SX:
        """``h(C x)`` as an SX expression of an SX state ``x``.

        Parameters
        ----------
        x : casadi.SX
            Symbolic state, ``(n, 1)``.

        Returns
        -------
        casadi.SX
            ``(p,)`` expression.
        """
        return self._out_fn(x)


def _no_names(value) -> bool:
    """``None`` or an empty list/tuple/array: "no names given" (the defaults apply)."""
    return value is None or (isinstance(value, (list, tuple, np.ndarray)) and len(value) == 0)


def _name_count(value, field: str) -> int:
    """How many names ``value`` holds (0 for none); a string or a non-sequence is refused here."""
    if _no_names(value):
        return 0
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        names_or_default(value, field, ())  # raises, naming what was given
    return len(value)


def _default_names(names: tuple[str, ...], prefix: str) -> bool:
    return names == tuple(f"{prefix}{i + 1}" for i in range(len(names)))


def _ranges(box: Polytope, rows: np.ndarray, label: str) -> np.ndarray:
    """``[min, max]`` of ``row . x`` over ``box`` for each row (two LPs per row), read-only ``(k, 2)``."""
    out = row_range(box.A, box.b, rows, problem=f"range of {label} x over the box", field="box",
                    labels=[f"{label}[{i}]" for i in range(rows.shape[0])])
    out.setflags(write=False)
    return out


def _check_function(fn: ScalarFunction, label: str, interval: np.ndarray) -> None:
    z = np.linspace(interval[0], interval[1], FUNCTION_CHECK_SAMPLES)
    for what, vals in (("values", fn.value(z)), ("derivatives", fn.deriv(z))):
        bad = ~np.isfinite(vals)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise ModelError(label, f"finite {what} on the operating box (argument in [{interval[0]:.6g}, {interval[1]:.6g}])",
                             f"{vals[k]} at argument {z[k]:.6g}")
    if fn.has_user_derivative:
        given, auto = fn.deriv(z), fn.deriv_autodiff(z)
        scale = 1.0 + float(np.max(np.abs(auto)))
        err = np.abs(given - auto)
        if np.max(err) > DERIVATIVE_CHECK_RTOL * scale:
            k = int(np.argmax(err))
            raise ModelError(f"{label}.derivative", "the derivative of expr (checked by automatic differentiation)",
                             f"{given[k]:.6g} instead of {auto[k]:.6g} at argument {z[k]:.6g}")
