"""Unknown parameters of a PWA system as constant states (e.g. an unknown backlash gap).

Paper 002 assumes the backlash gap ``alpha`` known, "seldom true in real powertrains" (Section 8).
In model (16) ``alpha`` enters linearly in exactly two places: the guards (``theta <= -alpha``,
``|theta| <= alpha``, ``theta >= alpha``) and the affine terms of the contact modes
(``T_w = k (theta -+ alpha)``).  Any parameter ``p`` that enters a PWA system (eq. 1 of paper
002) only through its affine terms ``a_i, c_i`` and its guards' right-hand sides ``g_i``, affinely,

``x+ = A_i x + B_i u + a_i(p)``,  ``y = C_i x + D_i u + c_i(p)``,  ``G_i [x; u] <= g_i(p)``,

is a constant state of the augmented PWA system over ``(x, p)``:

``[x; p]+ = [[A_i, a_i'], [0, I]] [x; p] + [B_i; 0] u + [a_i(p0) - a_i' p0; 0]``,
``y = [C_i, c_i'] [x; p] + D_i u + c_i(p0) - c_i' p0``,
``[G_x, -g_i', G_u] [x; p; u] <= g_i(p0) - g_i' p0``,

with ``p`` bounded by the user's interval: the joint estimation of state and parameter is then
Algorithm 3.1, the lookup observer and the mixed-integer moving-horizon problem (10) of the
augmented system, unchanged (the MIQP stays an MIQP).  :func:`augment_parameters` builds it from
a factory ``build(**params) -> PWASystem``: the derivatives ``a_i', c_i', g_i'`` by a difference
over each parameter's interval, then checked exactly at other points of the box (anything else
that moves with ``p`` -- ``A_i``, ``B_i``, ``C_i``, a guard's rows, the bounds -- is refused,
naming it, and so is a curvature: ``p`` must enter affinely).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..tolerances import AFFINE_PARAMETER_RTOL
from ..geometry.polytope import Polytope
from .pwa import PWAMode, PWASystem



@dataclass(frozen=True, eq=False)
class AugmentedSystem:
    """A PWA system with unknown parameters appended to its state (module docstring).

    Attributes
    ----------
    system : PWASystem
        The augmented system over ``(x, p)``; its last ``len(parameters)`` states are the parameters.
    base_names : tuple of str
        The original state names.
    parameters : tuple of str
        The parameters' names (the appended states).
    bounds : dict of str to (float, float)
        Each parameter's interval.
    build : callable
        The factory, for the system at a known parameter value (:meth:`at`).

    See Also
    --------
    augment_parameters : builds it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import augment_parameters
    >>> example = get_example("powertrain3")
    >>> augmented = augment_parameters(lambda alpha: example.build(alpha=alpha), {"alpha": (0.02, 0.08)})
    >>> augmented.parameters, augmented.base_names, augmented.bounds
    (('alpha',), ('theta', 'omega_m', 'omega_l'), {'alpha': (0.02, 0.08)})
    >>> augmented.augment_state(np.array([0.06, 39.0, 3.25]), {"alpha": 0.05})
    array([ 0.06, 39.  ,  3.25,  0.05])
    """

    system: PWASystem
    base_names: tuple[str, ...]
    parameters: tuple[str, ...]
    bounds: dict
    build: Callable[..., PWASystem]

    @property
    def n_base(self) -> int:
        return len(self.base_names)

    def augment_state(self, x, params: Mapping[str, float]) -> np.ndarray:
        """``[x; p]`` for a state of the original system and parameter values.

        Parameters
        ----------
        x : (n,) array_like
            State of the original system.
        params : mapping
            Value of every parameter.

        Returns
        -------
        (n + k,) ndarray
            The original state followed by the parameter values, in ``parameters`` order.
        """
        missing = [p for p in self.parameters if p not in params]
        if missing:
            raise ModelError("params", f"a value for each of {list(self.parameters)}", f"missing {missing}")
        return np.concatenate([np.asarray(x, dtype=float).reshape(-1), [float(params[p]) for p in self.parameters]])

    def at(self, **params: float) -> PWASystem:
        """The original system at the given parameter values (``build(**params)``).

        Returns
        -------
        PWASystem
            The system built at those parameter values.
        """
        return self.build(**params)


def _interval(name: str, value) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ModelError(f"parameters[{name!r}]", "an interval (lower, upper) of finite numbers", repr(value)) from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ModelError(f"parameters[{name!r}]", "an interval (lower, upper) with lower < upper, both finite", repr(value))
    return lo, hi


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.allclose(a, b, rtol=AFFINE_PARAMETER_RTOL, atol=AFFINE_PARAMETER_RTOL * (1 + np.abs(a).max(initial=0)))


def _data(system: PWASystem) -> list[tuple]:
    return [(md.A, md.B, md.C, md.D, md.guard.A, md.a, md.c, md.guard.b) for md in system.modes]


def augment_parameters(build: Callable[..., PWASystem], parameters: Mapping[str, tuple[float, float]], *,
                       names: Mapping[str, str] | None = None) -> AugmentedSystem:
    """The PWA system over ``(x, p)`` whose constant states ``p`` are unknown parameters of ``build``.

    Parameters
    ----------
    build : callable
        ``build(**{name: value}) -> PWASystem`` (e.g. ``powertrain3``, or an example's ``build``).
    parameters : mapping of str to (float, float)
        Each unknown parameter and its interval (e.g. ``{"alpha": (0.02, 0.08)}``).
    names : mapping of str to str, optional
        State names of the appended parameters (default: the parameter names).

    Returns
    -------
    AugmentedSystem
        The augmented system and what it was built from.

    Raises
    ------
    ModelError
        If ``build`` fails or does not return a PWA system, if a parameter changes anything but the
        affine terms and the guards' right-hand sides (naming the mode and the matrix), or if it
        does not enter affinely (the check at the box's other points fails).

    See Also
    --------
    AugmentedSystem : what it returns.

    Examples
    --------
    The backlash gap ``alpha`` of model (16), unknown in ``[0.02, 0.08]``, as a fourth state:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import augment_parameters
    >>> example = get_example("powertrain3")
    >>> augmented = augment_parameters(lambda alpha: example.build(alpha=alpha), {"alpha": (0.02, 0.08)})
    >>> augmented.system
    PWASystem(name='powertrain3 (tau=0.08333) with unknown alpha', n=4, m=1, p=1, modes=3)
    >>> augmented.system.state_names
    ('theta', 'omega_m', 'omega_l', 'alpha')
    """
    if not callable(build):
        raise ModelError("build", "a callable build(**params) -> PWASystem", type(build).__name__)
    if not isinstance(parameters, Mapping) or not parameters:
        raise ModelError("parameters", "a mapping {name: (lower, upper)} with at least one parameter", repr(parameters))
    pnames = tuple(str(k) for k in parameters)
    box = np.array([_interval(k, parameters[k]) for k in pnames])
    lo, hi = box[:, 0], box[:, 1]
    p0 = (lo + hi) / 2.0

    def system_at(p: np.ndarray) -> PWASystem:
        kw = dict(zip(pnames, (float(v) for v in p)))
        try:
            s = build(**kw)
        except ModelError:
            raise
        except Exception as exc:  # a user's factory: say which call failed
            raise ModelError("build", f"a factory accepting {list(pnames)}", f"build(**{kw}) raised {type(exc).__name__}: {exc}") from exc
        if not isinstance(s, PWASystem):
            raise ModelError("build", "a factory returning a PWASystem", type(s).__name__)
        return s

    base = system_at(p0)
    ref = _data(base)
    slopes = []  # per parameter: per mode (da, dc, dg)
    for j, name in enumerate(pnames):
        h = (hi[j] - lo[j]) / 2.0
        pj = p0.copy()
        pj[j] += h
        sj = system_at(pj)
        if len(sj.modes) != len(base.modes):
            raise ModelError(f"parameters[{name!r}]", "a parameter that keeps the number of modes",
                             f"{len(base.modes)} modes at {p0[j]:g}, {len(sj.modes)} at {pj[j]:g}")
        for label, x, y in (("state_bounds", base.state_bounds, sj.state_bounds), ("input_bounds", base.input_bounds, sj.input_bounds)):
            if (x is None) != (y is None) or (x is not None and not (_same(x.A, y.A) and _same(x.b, y.b))):
                raise ModelError(f"parameters[{name!r}]", "a parameter that leaves the state and input bounds alone", f"it changes {label}")
        per_mode = []
        for i, (r, d) in enumerate(zip(ref, _data(sj))):
            for label, a, b in zip(("A", "B", "C", "D", "guard rows"), r[:5], d[:5]):
                if not _same(a, b):
                    raise ModelError(f"parameters[{name!r}]", "a parameter entering only the affine terms a_i, c_i and the "
                                     "guards' right-hand sides", f"it changes {label} of mode {i} ({base.modes[i].name!r})")
            per_mode.append(tuple((np.asarray(d[k], dtype=float) - np.asarray(r[k], dtype=float)) / h for k in (5, 6, 7)))
        slopes.append(per_mode)
    # affine: the prediction from the slopes must be exact at other points of the box
    rng = np.random.default_rng(0)
    checks = [lo.copy(), hi.copy()] + [lo + (hi - lo) * rng.uniform(size=lo.size) for _ in range(2)]
    for p in checks:
        sp = system_at(p)
        for i, d in enumerate(_data(sp)):
            for k, label in zip((5, 6, 7), ("a", "c", "guard right-hand side")):
                pred = np.asarray(ref[i][k], dtype=float) + sum(slopes[j][i][k - 5] * (p[j] - p0[j]) for j in range(len(pnames)))
                if not _same(d[k], pred):
                    raise ModelError("parameters", "parameters entering affinely (the augmented system is exact only then)",
                                     f"{label} of mode {i} at {dict(zip(pnames, p.round(12).tolist()))} is not affine in them")
    n, q = base.n, len(pnames)
    modes = []
    for i, md in enumerate(base.modes):
        da = np.column_stack([slopes[j][i][0] for j in range(q)])
        dc = np.column_stack([slopes[j][i][1] for j in range(q)])
        dg = np.column_stack([slopes[j][i][2] for j in range(q)])
        A = np.block([[md.A, da], [np.zeros((q, n)), np.eye(q)]])
        B = np.vstack([md.B.reshape(n, -1), np.zeros((q, md.B.reshape(n, -1).shape[1]))])
        a = np.concatenate([md.a - da @ p0, np.zeros(q)])
        C = np.hstack([md.C.reshape(base.p, n), dc])
        c = (np.zeros(base.p) if md.c is None else md.c) - dc @ p0
        G = md.guard.A
        guard = Polytope(np.hstack([G[:, :n], -dg, G[:, n:]]), md.guard.b - dg @ p0)
        modes.append(PWAMode(A, B, a, C, guard, D=md.D, c=c, name=md.name))
    extra = tuple((names or {}).get(k, k) for k in pnames)
    state_names = tuple(base.state_names) + extra
    X = base.state_bounds
    Xa = Polytope(np.vstack([np.hstack([X.A, np.zeros((X.A.shape[0], q))]),
                             np.hstack([np.zeros((q, n)), np.eye(q)]), np.hstack([np.zeros((q, n)), -np.eye(q)])]),
                  np.concatenate([X.b, hi, -lo]), state_names)
    system = PWASystem(tuple(modes), Xa, base.input_bounds, state_names, base.input_names, base.output_names,
                       Ts=base.Ts, name=f"{base.name} with unknown {', '.join(pnames)}", partition=base.partition)
    return AugmentedSystem(system, tuple(base.state_names), pnames, {k: (float(a), float(b)) for k, (a, b) in zip(pnames, box)},
                           build)
