"""The ranges a model's signals can take: what a runtime observer judges its samples against.

A runtime observer refuses a sample whose input or output lies outside what its model can
produce by more than :data:`~hybobs_opt.defaults.RANGE_MARGIN` of the range's width, and never
flags ``observable`` an estimate outside the model's state set (DESIGN.md, "Conventions": a
runtime observer judges a sample against the model, not only its type).  This module computes
those ranges once, when the observer is built:

* :func:`state_range` -- the bounding box of the state set (``state_bounds`` or the operating
  box), by LPs;
* :func:`input_range` -- the bounding box of the declared input set (``None`` without one);
* :func:`output_range` -- per output, ``[min, max]`` over every mode or location of the affine
  output map on its region intersected with the state and input sets (two LPs per output and
  mode), or of a nonlinear output sampled on its argument interval and refined.

An entry is ``-inf`` / ``+inf`` where the model leaves the signal unbounded (no input bounds and
an output with a direct feedthrough): that side is not judged.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..defaults import OUTPUT_RANGE_SAMPLES
from ..geometry.lp import row_range
from ..geometry.polytope import Polytope

Range = tuple[np.ndarray, np.ndarray]


def state_range(system: Any) -> Range | None:
    """Bounding box of the state set (``state_bounds``, or ``box`` of a scalar-nonlinear system)."""
    P = getattr(system, "state_bounds", None)
    if P is None:
        P = getattr(system, "box", None)
    if not isinstance(P, Polytope):
        return None
    r = row_range(P.A, P.b, np.eye(P.dim), problem="state range", field="state_bounds", labels=P.names,
                  allow_unbounded=True)
    return r[:, 0].copy(), r[:, 1].copy()


def input_range(system: Any) -> Range | None:
    """Bounding box of the input set, ``None`` when the model declares none (or has no inputs)."""
    P = getattr(system, "input_bounds", None)
    if not isinstance(P, Polytope) or P.dim == 0:
        return None
    r = row_range(P.A, P.b, np.eye(P.dim), problem="input range", field="input_bounds", labels=P.names,
                  allow_unbounded=True)
    return r[:, 0].copy(), r[:, 1].copy()


def output_range(system: Any) -> Range | None:
    """Per output ``[min, max]`` of what the model can produce on its state (and input) set.

    PWA systems: over every mode ``i``, ``C_i x + D_i u + c_i`` on ``Q_i`` intersected with the
    state and input bounds.  Hybrid automata with affine outputs: the same over each location's
    invariant.  Scalar-nonlinear systems (paper 004): each ``h_j(C_j x)`` on its argument interval
    over the box, sampled and refined.  ``None`` for a system of another kind or with a nonlinear
    output callable whose range cannot be bounded this way.
    """
    from .hybrid import HybridAutomaton
    from .pwa import PWASystem
    from .scalar_nonlinear import ScalarNonlinearSystem

    if isinstance(system, ScalarNonlinearSystem):
        return _scalar_nonlinear_output_range(system)
    if isinstance(system, PWASystem):
        pieces = [(mode.guard, mode.C, mode.D, mode.c) for mode in system.modes]
    elif isinstance(system, HybridAutomaton):
        if any(loc.C is None for loc in system.locations):
            return None
        pieces = [(loc.invariant, loc.C, loc.D, loc.c) for loc in system.locations]
    else:
        return None
    n, m, p = system.n, system.m, system.p
    X, U = system.state_bounds, system.input_bounds
    lo, hi = np.full(p, np.inf), np.full(p, -np.inf)
    for region, C, D, c in pieces:
        Z = _region_over_xu(region, X, U, n, m)
        D = np.zeros((p, m)) if D is None else np.asarray(D, dtype=float).reshape(p, m)
        c = np.zeros(p) if c is None else np.asarray(c, dtype=float).reshape(p)
        rows = np.hstack([np.asarray(C, dtype=float).reshape(p, n), D])
        r = row_range(Z.A, Z.b, rows, problem="output range", field="modes", allow_unbounded=True, allow_empty=True)
        if r is None:  # a mode that never applies on the state set
            continue
        lo, hi = np.minimum(lo, r[:, 0] + c), np.maximum(hi, r[:, 1] + c)
    if np.any(lo > hi):
        return None
    return lo, hi


def _region_over_xu(region: Polytope, X: Polytope, U: Polytope | None, n: int, m: int) -> Polytope:
    """``region`` (over ``x`` or ``(x, u)``) intersected with ``X`` (and ``U``), over ``(x, u)``."""
    Z = region if region.dim == n + m else region.lift(n + m, range(n))
    Z = Z.intersect(X.lift(n + m, range(n)))
    if U is not None and m:
        Z = Z.intersect(U.lift(n + m, range(n, n + m)))
    return Z


def _scalar_nonlinear_output_range(system: Any) -> Range:
    from scipy.optimize import minimize_scalar

    lo, hi = [], []
    for fn, (a, b) in zip(system.h, system.h_ranges):
        z = np.linspace(a, b, OUTPUT_RANGE_SAMPLES)
        v = fn.value(z)
        ext = []
        for sign, k in ((1.0, int(np.argmin(v))), (-1.0, int(np.argmax(v)))):
            # refine the sampled extreme inside its two neighbouring cells
            za, zb = z[max(k - 1, 0)], z[min(k + 1, z.size - 1)]
            best = float(v[k])
            if zb > za:
                r = minimize_scalar(lambda t: sign * float(fn.value(np.array([t]))[0]), bounds=(za, zb), method="bounded",
                                    options={"xatol": 1e-12 * max(1.0, abs(za), abs(zb))})
                if np.isfinite(r.fun):
                    best = min(best, sign * r.fun) if sign > 0 else max(best, -r.fun)
            ext.append(best)
        lo.append(ext[0])
        hi.append(ext[1])
    return np.array(lo), np.array(hi)


__all__ = ["input_range", "output_range", "state_range"]
