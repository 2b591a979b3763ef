"""Jacobian bounds (eqs. 4-5 of paper 004) and the monotonicity of every scalar function.

For each ``f_i`` (argument ``E_i x``) and each nonlinear output ``h_j`` (argument ``C_j x``) the
bounds ``U_i <= f_i' <= V_i`` and ``M_j <= h_j' <= N_j`` are computed over the argument interval
that the operating box (or one region of it) allows:

* **method "sampled+refined"** (default): the derivative is evaluated on a dense grid
  (:data:`~hybobs_opt.defaults.JACOBIAN_BOUND_SAMPLES` points, CasADi), every sign change of the
  *second* derivative between two samples is refined to a critical point of ``f'`` by ``brentq``,
  and the bounds are the extreme values over the end points, the samples and the critical points.
  They are then widened outward by :data:`~hybobs_opt.tolerances.JACOBIAN_BOUND_RTOL` times
  ``max |f'|`` (the margin is stored on the result), except across zero: a derivative whose
  sampled extremes keep one sign keeps it in the bounds (so a monotonic function never gets a
  sector with ``U V < 0``).  Exact up to rounding unless ``f''`` changes sign twice inside one
  sampling cell.
* **method "user"**: a derivative range supplied by the user (no margin); it is checked against
  the samples and rejected when the derivative leaves it.
* **method "linear"**: an identity output, ``M_j = N_j = 1``.

A function is *monotonic* on the interval when its derivative keeps one sign (to
:data:`~hybobs_opt.tolerances.MONOTONIC_RTOL`); :func:`slope_change_points` and
:func:`monotonic_pieces` split a scheduling range at the points where some function changes
direction (the regions of Section 5: "a nonlinear function on a compact set has finite local
extrema and can always therefore be represented using piecewise monotonic functions").
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy.optimize import brentq

from ..defaults import JACOBIAN_BOUND_CACHE_SIZE, JACOBIAN_BOUND_SAMPLES
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarFunction, ScalarNonlinearSystem
from ..tolerances import JACOBIAN_BOUND_RTOL, MONOTONIC_RTOL
from .schedule import SchedulingRegion, argument_intervals, coordinate_index, make_region


NONDECREASING = "nondecreasing"
NONINCREASING = "nonincreasing"
CONSTANT = "constant"
NON_MONOTONIC = "non-monotonic"

_SECOND: "weakref.WeakKeyDictionary[ScalarFunction, ca.Function]" = weakref.WeakKeyDictionary()

#: Per function, the sampled bounds already computed, by interval (least recently used dropped
#: beyond :data:`~hybobs_opt.defaults.JACOBIAN_BOUND_CACHE_SIZE`).  A ``DerivativeBound`` is
#: immutable, so one object can be handed out again.
_BOUND_CACHE: "weakref.WeakKeyDictionary[ScalarFunction, OrderedDict]" = weakref.WeakKeyDictionary()


def _second_derivative(fn: ScalarFunction) -> ca.Function:
    """CasADi ``f''`` (derivative of the function's own derivative), built once per function."""
    out = _SECOND.get(fn)
    if out is None:
        z = ca.SX.sym("z")
        out = ca.Function("d2f", [z], [ca.jacobian(fn.sx_deriv(z), z)])
        _SECOND[fn] = out
    return out


def _eval(f: ca.Function, z: np.ndarray) -> np.ndarray:
    return np.asarray(f(np.asarray(z, dtype=float).reshape(1, -1)), dtype=float).reshape(-1)


@dataclass(frozen=True)
class DerivativeBound:
    """Bounds of one scalar function's derivative over an argument interval (eq. 4 or 5).

    Parameters
    ----------
    name : str
        The function's name.
    kind : str
        ``"f"`` (process, eq. 5) or ``"h"`` (output, eq. 4).
    index : int
        ``i`` of ``f_i`` or ``j`` of ``h_j``.
    interval : tuple of float
        The argument interval ``[min E_i x, max E_i x]`` over the region.
    lower, upper : float
        The bounds used by the LMIs (``U_i, V_i`` or ``M_j, N_j``), widened by ``margin``.
    raw_lower, raw_upper : float
        The extreme derivative values found, before widening.
    argmin, argmax : float
        Arguments where they are attained.
    method : str
        ``"sampled+refined"``, ``"user"`` or ``"linear"``.
    samples : int
        Grid size (0 for user and linear bounds).
    margin : float
        Outward widening applied on each side.

    See Also
    --------
    derivative_bound : Computes one.
    JacobianBounds : All the bounds of a system over a region.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> bounds = jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80)))
    >>> b = bounds.f[0]
    >>> b.name, b.kind, b.monotonic
    ('V cos(psi)', 'f', True)
    >>> round(b.lower, 3), round(b.upper, 3)
    (-9.848, 0.0)
    """

    name: str
    kind: str
    index: int
    interval: tuple[float, float]
    lower: float
    upper: float
    raw_lower: float
    raw_upper: float
    argmin: float
    argmax: float
    method: str
    samples: int
    margin: float

    @property
    def scale(self) -> float:
        return max(abs(self.raw_lower), abs(self.raw_upper))

    @property
    def monotonicity(self) -> str:
        """``nondecreasing`` / ``nonincreasing`` / ``constant`` / ``non-monotonic`` on the interval."""
        tol = MONOTONIC_RTOL * self.scale
        up = self.lower >= -tol
        down = self.upper <= tol
        if up and down:
            return CONSTANT
        if up:
            return NONDECREASING
        if down:
            return NONINCREASING
        return NON_MONOTONIC

    @property
    def monotonic(self) -> bool:
        return self.monotonicity != NON_MONOTONIC

    @property
    def sector_product(self) -> float:
        """``lower * upper``: negative exactly for a non-monotonic function (Theorems 2-4)."""
        return self.lower * self.upper

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"name": self.name, "kind": self.kind, "index": self.index, "interval": list(self.interval),
                "lower": self.lower, "upper": self.upper, "argmin": self.argmin, "argmax": self.argmax,
                "monotonicity": self.monotonicity, "method": self.method, "samples": self.samples,
                "margin": self.margin}


def derivative_bound(
    fn: ScalarFunction,
    lo: float,
    hi: float,
    *,
    kind: str = "f",
    index: int = 0,
    given: tuple[float, float] | None = None,
    samples: int = JACOBIAN_BOUND_SAMPLES,
) -> DerivativeBound:
    """Bounds of ``fn'`` over ``[lo, hi]`` (eqs. 4-5 of paper 004); see the module for the method.

    Parameters
    ----------
    fn : ScalarFunction
    lo, hi : float
        Argument interval (``lo <= hi``; a single point is allowed).
    kind, index : str, int
        Labels (``"f"``/``"h"`` and the function's index) carried into the result.
    given : (float, float), optional
        A user-supplied derivative range; used as is after checking it against the samples.
    samples : int
        Grid size.

    Returns
    -------
    DerivativeBound
        The bounds ``lower <= fn' <= upper`` on the interval, with the raw sampled extremes, where
        they are reached and the method used.

    Raises
    ------
    ModelError
        A derivative that is NaN or infinite on the interval, a ``given`` range with its lower
        bound above its upper bound or not finite, or a ``given`` range the derivative leaves.

    See Also
    --------
    jacobian_bounds : The bounds of every function of a system.
    slope_change_points : Where ``fn'`` changes sign.

    Examples
    --------
    >>> import numpy as np
    >>> import math
    >>> from hybobs_opt.lmi import derivative_bound
    >>> from hybobs_opt.systems import ScalarFunction
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> b = derivative_bound(sine, 0.0, math.pi / 2)
    >>> round(b.lower, 3), round(b.upper, 3), b.monotonic
    (0.0, 1.0, True)
    """
    if given is None:
        # The sampled bounds depend only on the function and the interval: a bisection over regions
        # and every later design of the same system ask again for the same intervals.
        key = (float(lo), float(hi), kind, int(index), int(samples))
        cache = _BOUND_CACHE.get(fn)
        if cache is None:
            cache = _BOUND_CACHE[fn] = OrderedDict()
        out = cache.get(key)
        if out is None:
            out = cache[key] = _derivative_bound(fn, lo, hi, kind, index, None, samples)
            if len(cache) > JACOBIAN_BOUND_CACHE_SIZE:
                cache.popitem(last=False)
        else:
            cache.move_to_end(key)
        return out
    return _derivative_bound(fn, lo, hi, kind, index, given, samples)


def _derivative_bound(fn: ScalarFunction, lo: float, hi: float, kind: str, index: int,
                      given: tuple[float, float] | None, samples: int) -> DerivativeBound:
    """:func:`derivative_bound` computed (no cache)."""
    label = f"{kind}[{index}] ({fn.name})"
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        raise ModelError(f"{label} argument interval", "finite lo <= hi", f"[{lo}, {hi}]")
    samples = max(int(samples), 3)
    z = np.linspace(lo, hi, samples) if hi > lo else np.array([lo])
    d = fn.deriv(z)
    bad = ~np.isfinite(d)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise ModelError(f"{label} derivative", f"finite values on [{lo:.6g}, {hi:.6g}] (bounded Jacobian, eq. 4-5)",
                         f"{d[k]} at argument {z[k]:.6g}")
    interval = (float(lo), float(hi))
    if given is not None:
        try:
            g_lo, g_hi = (float(v) for v in given)
        except (TypeError, ValueError):
            raise ModelError(f"{label} derivative range", "a pair (lower, upper)", repr(given)) from None
        if not (np.isfinite(g_lo) and np.isfinite(g_hi)):
            raise ModelError(f"{label} derivative range", "finite bounds", f"({g_lo}, {g_hi})")
        if g_lo > g_hi:
            raise ModelError(f"{label} derivative range", "lower bound <= upper bound", f"({g_lo}, {g_hi})")
        scale = max(abs(g_lo), abs(g_hi), float(np.max(np.abs(d))))
        tol = JACOBIAN_BOUND_RTOL * scale
        if d.min() < g_lo - tol or d.max() > g_hi + tol:
            k = int(np.argmin(d)) if d.min() < g_lo - tol else int(np.argmax(d))
            raise ModelError(f"{label} derivative range", f"a range containing the derivative on [{lo:.6g}, {hi:.6g}]",
                             f"({g_lo:.6g}, {g_hi:.6g}) but {fn.name}' = {d[k]:.6g} at {z[k]:.6g}")
        return DerivativeBound(fn.name, kind, index, interval, g_lo, g_hi, g_lo, g_hi, float(z[np.argmin(d)]),
                               float(z[np.argmax(d)]), "user", 0, 0.0)

    cand_z = [z[np.argmin(d)], z[np.argmax(d)]]
    cand_d = [d.min(), d.max()]
    if z.size > 2:
        d2f = _second_derivative(fn)
        s = _eval(d2f, z)
        ok = np.isfinite(s)
        sign = np.sign(s)
        for k in np.nonzero(ok[:-1] & ok[1:] & (sign[:-1] * sign[1:] < 0))[0]:
            try:
                zc = brentq(lambda t: float(d2f(t)), z[k], z[k + 1], xtol=1e-14 * max(1.0, abs(z[k])), maxiter=200)
            except (ValueError, RuntimeError):
                continue
            dc = float(fn.deriv(np.array([zc]))[0])
            if np.isfinite(dc):
                cand_z.append(zc)
                cand_d.append(dc)
    cz, cd = np.array(cand_z), np.array(cand_d)
    raw_lo, raw_hi = float(cd.min()), float(cd.max())
    margin = JACOBIAN_BOUND_RTOL * max(abs(raw_lo), abs(raw_hi))
    lower, upper = raw_lo - margin, raw_hi + margin
    # The widening never makes a derivative that keeps one sign look sign-changing: cos' = -sin on
    # [0, pi/2] has the extreme 0 at the end point, and a bound of +1e-6 there would turn the
    # S-procedure term -U V |E v|^2 positive (a "non-monotonic" obstruction that is not there).
    if raw_lo >= 0.0 > lower:
        lower = 0.0
    if raw_hi <= 0.0 < upper:
        upper = 0.0
    return DerivativeBound(fn.name, kind, index, interval, lower, upper, raw_lo, raw_hi,
                           float(cz[np.argmin(cd)]), float(cz[np.argmax(cd)]), "sampled+refined", int(z.size), margin)


def _linear_bound(j: int, interval: tuple[float, float]) -> DerivativeBound:
    return DerivativeBound("identity", "h", j, interval, 1.0, 1.0, 1.0, 1.0, interval[0], interval[0], "linear", 0, 0.0)


@dataclass(frozen=True)
class JacobianBounds:
    """All the bounds of eqs. (4)-(5) for one system over one region (or the whole box).

    Parameters
    ----------
    region : SchedulingRegion or None
        ``None`` for the whole operating box.
    f : tuple of DerivativeBound
        ``U_i, V_i`` of each ``f_i``.
    h : tuple of DerivativeBound
        ``M_j, N_j`` of each ``h_j`` (``method == "linear"`` for identity outputs).
    linear_outputs : tuple of bool
        Per output, whether ``h_j`` is the identity (its bounds are not used in the sector).

    See Also
    --------
    jacobian_bounds : Computes them.
    ObserverLMI.solve : Solves the observer LMI for them.
    plot_jacobian_bounds : Draws the derivatives with their bounds.

    Examples
    --------
    >>> import numpy as np
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> bounds = jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80)))
    >>> [b.name for b in bounds.f]
    ['V cos(psi)', 'V sin(psi)', 'V/(l_f+l_r) tan(delta_f)']
    >>> np.round(bounds.U, 3), np.round(bounds.V, 3)
    (array([-9.848,  1.736,  3.731]), array([ 0.   , 10.   ,  3.847]))
    >>> bounds.nonmonotonic
    []
    """

    region: SchedulingRegion | None
    f: tuple[DerivativeBound, ...]
    h: tuple[DerivativeBound, ...]
    linear_outputs: tuple[bool, ...] = field(default=())

    @property
    def U(self) -> np.ndarray:
        return np.array([b.lower for b in self.f])

    @property
    def V(self) -> np.ndarray:
        return np.array([b.upper for b in self.f])

    @property
    def M(self) -> np.ndarray:
        """Lower bounds of the *nonlinear* outputs' derivatives."""
        return np.array([b.lower for b, lin in zip(self.h, self.linear_outputs) if not lin])

    @property
    def N(self) -> np.ndarray:
        return np.array([b.upper for b, lin in zip(self.h, self.linear_outputs) if not lin])

    @property
    def nonmonotonic(self) -> list[DerivativeBound]:
        return [b for b in (*self.f, *self.h) if not b.monotonic]

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"region": None if self.region is None else self.region.to_dict(),
                "f": [b.to_dict() for b in self.f], "h": [b.to_dict() for b in self.h]}


def jacobian_bounds(
    system: ScalarNonlinearSystem,
    region: SchedulingRegion | None = None,
    *,
    given: Mapping[tuple[str, int], tuple[float, float]] | None = None,
    samples: int = JACOBIAN_BOUND_SAMPLES,
) -> JacobianBounds:
    """Bounds ``U, V`` (eq. 5) and ``M, N`` (eq. 4) of ``system`` over ``region``.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    region : SchedulingRegion, optional
        Restrict one coordinate of the operating box (default: the whole box).
    given : mapping, optional
        User derivative ranges keyed by ``("f", i)`` or ``("h", j)``.
    samples : int
        Grid size of the sampled method.

    Returns
    -------
    JacobianBounds
        One :class:`DerivativeBound` per process function ``f_i`` (``U_i, V_i``, eq. 5) and per output
        function ``h_j`` (``M_j, N_j``, eq. 4).

    See Also
    --------
    derivative_bound : The bound of one function.
    monotonic_pieces : Where the functions change direction.
    ObserverLMI : The observer LMI built on these bounds.

    Examples
    --------
    ``V cos(psi)`` is decreasing on 0-80 deg, ``V sin(psi)`` increasing: the box has one sign per
    function.

    >>> import numpy as np
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> bounds = jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80)))
    >>> np.round(bounds.U, 2), np.round(bounds.V, 2)
    (array([-9.85,  1.74,  3.73]), array([ 0.  , 10.  ,  3.85]))

    Over 0-140 deg ``V sin(psi)`` is no longer monotonic (its peak is at 90 deg):

    >>> wide = jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140)))
    >>> [b.name for b in wide.nonmonotonic]
    ['V sin(psi)']
    """
    given = dict(given or {})
    for key in given:
        if not (isinstance(key, tuple) and len(key) == 2 and key[0] in ("f", "h")):
            raise ModelError("given", "keys ('f', i) or ('h', j)", repr(key))
        size = system.r if key[0] == "f" else system.p
        if not 0 <= int(key[1]) < size:
            raise ModelError("given", f"an index of {key[0]} in [0, {size})", repr(key))
    f_int = argument_intervals(system, system.E, region) if system.r else np.zeros((0, 2))
    h_int = argument_intervals(system, system.C, region)
    fb = tuple(derivative_bound(fn, *f_int[i], kind="f", index=i, given=given.get(("f", i)), samples=samples)
               for i, fn in enumerate(system.f))
    lin = system.linear_outputs
    hb = tuple(_linear_bound(j, tuple(h_int[j])) if lin[j] and ("h", j) not in given
               else derivative_bound(fn, *h_int[j], kind="h", index=j, given=given.get(("h", j)), samples=samples)
               for j, fn in enumerate(system.h))
    return JacobianBounds(region, fb, hb, tuple(lin[j] and ("h", j) not in given for j in range(system.p)))


def slope_change_points(fn: ScalarFunction, lo: float, hi: float, samples: int = JACOBIAN_BOUND_SAMPLES) -> np.ndarray:
    """Arguments in ``(lo, hi)`` where ``fn'`` changes sign (local extrema of ``fn``), refined by brentq.

    Parameters
    ----------
    fn : ScalarFunction
        The function.
    lo, hi : float
        The argument interval.
    samples : int, default JACOBIAN_BOUND_SAMPLES
        Grid size on which sign changes of ``fn'`` are looked for (at least 3).

    Returns
    -------
    (k,) array
        The arguments where ``fn'`` changes sign, sorted (empty when ``fn`` is monotonic).

    Raises
    ------
    ModelError
        If ``fn'`` is not finite on the grid.

    See Also
    --------
    monotonic_pieces : Splits a system's scheduling range at these points.
    derivative_bound : Bounds of ``fn'`` on an interval.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import slope_change_points
    >>> from hybobs_opt.systems import ScalarFunction
    >>> import casadi as ca
    >>> cosine = ScalarFunction("cos", ca.cos, lambda z: -ca.sin(z))   # CasADi expressions
    >>> np.round(slope_change_points(cosine, -1.0, 7.0), 4)
    array([3.1416, 6.2832])
    """
    z = np.linspace(lo, hi, max(int(samples), 3))
    d = fn.deriv(z)
    if not np.all(np.isfinite(d)):
        k = int(np.argmax(~np.isfinite(d)))
        raise ModelError(f"{fn.name} derivative", f"finite values on [{lo:.6g}, {hi:.6g}]", f"{d[k]} at {z[k]:.6g}")
    out = []
    sign = np.sign(d)
    for k in np.nonzero(sign[:-1] * sign[1:] < 0)[0]:
        out.append(brentq(lambda t: float(fn.deriv(np.array([t]))[0]), z[k], z[k + 1], xtol=1e-13 * max(1.0, abs(z[k]))))
    return np.array(out)


def monotonic_pieces(
    system: ScalarNonlinearSystem,
    coordinate: int | str,
    lo: float | None = None,
    hi: float | None = None,
    samples: int = 4 * JACOBIAN_BOUND_SAMPLES,
) -> tuple[np.ndarray, list[SchedulingRegion]]:
    """Split a scheduling range where any function of that coordinate changes direction.

    Every ``f_i``/``h_j`` whose argument row depends on the coordinate is examined along the
    coordinate (the other states at the centre of the box, which is exact when the argument is the
    coordinate itself, as in both examples of paper 004).  On each piece every such function is
    monotonic (Section 5 of paper 004).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    coordinate : int or str
        The scheduling state (index or name).
    lo, hi : float, optional
        The range in model units (default: the operating box).
    samples : int, default 4 * JACOBIAN_BOUND_SAMPLES
        Grid size of :func:`slope_change_points`.

    Returns
    -------
    breakpoints : array
        The slope-change points, sorted.
    pieces : list of SchedulingRegion
        The intervals between consecutive breakpoints (and the range ends).

    See Also
    --------
    slope_change_points : The breakpoints of one function.
    regions_from_switch_points : Overlapping regions around chosen switching points.
    diagnose : Reports the pieces with the LMI's verdict.

    Examples
    --------
    >>> import numpy as np
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import monotonic_pieces
    >>> breakpoints, pieces = monotonic_pieces(vehicle, "psi", 0.0, math.radians(140))
    >>> np.round(np.degrees(breakpoints), 3)
    array([90.])
    >>> [(round(math.degrees(p.lo)), round(math.degrees(p.hi))) for p in pieces]
    [(0, 90), (90, 140)]
    """
    k = coordinate_index(system, coordinate)
    lo = float(system.box_lower[k]) if lo is None else float(lo)
    hi = float(system.box_upper[k]) if hi is None else float(hi)
    make_region(system, k, lo, hi)  # validates the range
    centre = 0.5 * (system.box_lower + system.box_upper)
    pts: list[float] = []
    for rows, fns in ((system.E, system.f), (system.C, system.h)):
        for row, fn in zip(rows, fns):
            if row[k] == 0 or fn.is_identity:
                continue
            offset = float(row @ centre - row[k] * centre[k])
            a, b = sorted((offset + row[k] * lo, offset + row[k] * hi))
            for zc in slope_change_points(fn, a, b, samples):
                pts.append((zc - offset) / row[k])
    pts_arr = np.unique(np.round(np.array(sorted(pts)), 12)) if pts else np.zeros(0)
    pts_arr = pts_arr[(pts_arr > lo) & (pts_arr < hi)]
    edges = [lo, *pts_arr.tolist(), hi]
    pieces = [make_region(system, k, a, b, i) for i, (a, b) in enumerate(zip(edges[:-1], edges[1:]))]
    return pts_arr, pieces
