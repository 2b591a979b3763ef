"""Observability canonical form of switched systems, and Theorem 1 of paper 001 for linear pieces.

The step-by-step sliding-mode observer of paper 001 (Djemai, Manamanni, Barbot; eq. 5) works on
systems in the canonical form (4)::

    z1' = z2, ..., z_{n-1}' = z_n, z_n' = f_q(z),   y = z1,   q chosen by sigma(z).

This module brings a :class:`~hybobs_opt.systems.hybrid.HybridAutomaton` into that form:

- **Affine locations** (``x' = A_q x + E_q``, ``y = C x + c``, like Example 3): the coordinates
  are the output and its derivatives, ``z_{k+1} = y^{(k)} = C A_q^k x + C A_q^{k-1} E_q``
  (Fliess' observability form, Section 2 of paper 001), i.e. ``z = T x + d`` with ``T`` the
  observability matrix ``[C; C A_q; ...; C A_q^{n-1}]``.  Each location must be observable
  (rank ``T_q = n``, Assumption 1b) and the coordinates must be the same in every location
  (otherwise there is no single form (4); the per-location transformations are computed and
  reported in the error).  Then ``z_n' = alpha_q . z + beta_q`` and the invariants, hence the
  switching function, are rewritten in ``z``.
- **Nonlinear (callable) locations** (Example 2): the flow must already be in form (4), which is
  checked on samples of the operating box (``x_k' = x_{k+1}`` for ``k < n``, ``y = x1``).

:func:`theorem1` evaluates the sufficient observability conditions of Theorem 1 (sets ``M``,
``S``, ``L``) for two affine locations.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from ..errors import ModelError
from ..defaults import DERIVATIVE_BOUND_MARGIN, DERIVATIVE_BOUND_SAMPLES, TRIANGULAR_CHECK_SAMPLES
from ..tolerances import CANONICAL_FORM_RTOL, MEMBERSHIP_RTOL, RANK_RTOL, TRIANGULAR_CHECK_RTOL

from .hybrid import HybridAutomaton

__all__ = [
    "LocationTransform",
    "ObservabilityForm",
    "SwitchingFunction",
    "Theorem1Result",
    "location_transforms",
    "observability_form",
    "observability_matrix",
    "theorem1",
    "theorem1_pairs",
]


# ---------------------------------------------------------------------------------- data types
@dataclass(frozen=True)
class LocationTransform:
    """The observability coordinates of one affine location (paper 001, Section 2).

    ``z = T x + d`` with ``z_{k+1} = y^{(k)}``; in these coordinates the location reads
    ``z_k' = z_{k+1}`` (``k < n``), ``z_n' = alpha . z + beta``.

    Parameters
    ----------
    location : int
    name : str
    T : (n, n) array
        Observability matrix ``[C; C A; ...; C A^{n-1}]``.
    d : (n,) array
        Offsets ``(c, C E, C A E, ..., C A^{n-2} E)``.
    rank : int
        Rank of ``T`` in box-scaled coordinates (Assumption 1b needs ``n``).
    alpha : (n,) array or None
        ``C A^n T^{-1}`` (``None`` when ``T`` is singular).
    beta : float or None
        ``C A^{n-1} E - alpha . d``.

    See Also
    --------
    location_transforms : computes them.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import location_transforms
    >>> first = location_transforms(chua)[0]
    >>> first.T.shape, round(first.beta, 3)
    ((3, 3), -55.102)
    """

    location: int
    name: str
    T: np.ndarray
    d: np.ndarray
    rank: int
    alpha: np.ndarray | None
    beta: float | None

    @property
    def observable(self) -> bool:
        return self.rank == self.T.shape[0]


@dataclass(frozen=True)
class SwitchingFunction:
    """One switching function ``sigma`` of the automaton, in ``x`` and in ``z``.

    ``sigma(x) = x_row . x`` and ``sigma(z) = z_row . z + z_offset`` are the same function; the
    locations change where ``sigma`` crosses one of ``thresholds``.  For Example 3 of paper 001,
    ``sigma(x) = x1`` and ``sigma(z) = (z3 + z2)/c1 - z1`` with thresholds ``-1, 1``.

    Parameters
    ----------
    x_row : (n,) array
        Coefficients of ``sigma`` in ``x``.
    z_row : (n,) array
        Coefficients of ``sigma`` in ``z``.
    z_offset : float
        Constant term in ``z``.
    thresholds : tuple of float
        Values of ``sigma`` at which the location changes.

    See Also
    --------
    ObservabilityForm : holds one per switching surface.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import observability_form
    >>> sigma = observability_form(chua).switching[0]
    >>> sigma.x_row, sigma.thresholds                    # sigma(x) = x1, crossing -1 or 1
    (array([1., 0., 0.]), (-1.0, 1.0))
    """

    x_row: np.ndarray
    z_row: np.ndarray
    z_offset: float
    thresholds: tuple[float, ...]

    def of_x(self, x) -> float:
        """``sigma(x) = x_row . x``.

        Parameters
        ----------
        x : (n,) array_like
            Original state.

        Returns
        -------
        float
            ``sigma(x)``.
        """
        return float(self.x_row @ np.asarray(x, dtype=float))

    def of_z(self, z) -> float:
        """``sigma(z) = z_row . z + z_offset``.

        Parameters
        ----------
        z : (n,) array_like
            Canonical state.

        Returns
        -------
        float
            ``sigma(z)``.
        """
        return float(self.z_row @ np.asarray(z, dtype=float) + self.z_offset)


@dataclass(frozen=True, eq=False)
class ObservabilityForm:
    """A hybrid automaton in the canonical form (4) of paper 001, ready for the observer (5).

    Parameters
    ----------
    automaton : HybridAutomaton
        The original model.
    T, T_inv : (n, n) arrays
        ``z = T x + d``, ``x = T_inv (z - d)`` (identity for a system already in form (4)).
    d : (n,) array
    alpha : (L, n) array or None
        ``z_n' = alpha[q] . z + beta[q]`` for affine automata; ``None`` for callable flows.
    beta : (L,) array or None
    switching : tuple of SwitchingFunction
        The switching functions in ``z`` (from the invariants).
    z_lower, z_upper : (n,) arrays
        Box containing ``T X + d`` (``X`` = the automaton's operating set): the range of every
        canonical state.  The observer clips its estimate to it.
    f_lower, f_upper : float
        Range of ``z_n' = f_q(z)`` over ``X`` and every location (exact for affine flows, sampled
        and widened by :data:`~hybobs_opt.defaults.DERIVATIVE_BOUND_MARGIN` for callable ones).
    f_bound_method : str
        ``"interval"`` (exact) or ``"sampled"``.
    transforms : tuple of LocationTransform
        Per-location coordinates (affine automata), all equal to ``(T, d)``.
    names : tuple of str
        Names of the canonical states (``z1 .. zn``; the state names when ``T`` is the identity).
    invariant_G, invariant_g, invariant_starts
        The invariants rewritten in ``z``: ``invariant_G z <= invariant_g`` (rows unit-norm in
        box-scaled ``z``, right-hand side with the membership slack), the rows of location ``q``
        being ``invariant_starts[q]:invariant_starts[q + 1]``.

    See Also
    --------
    observability_form : computes it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> import numpy as np
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(chua)
    >>> x = np.array([0.5, 0.1, -0.2])
    >>> np.allclose(form.to_x(form.to_z(x)), x)          # the coordinates round-trip
    True
    >>> form.beta.round(3)                               # last dynamics z3' = alpha_q . z + beta_q
    array([-55.102,   0.   ,  55.102])
    """

    automaton: HybridAutomaton
    T: np.ndarray
    T_inv: np.ndarray
    d: np.ndarray
    alpha: np.ndarray | None
    beta: np.ndarray | None
    switching: tuple[SwitchingFunction, ...]
    z_lower: np.ndarray
    z_upper: np.ndarray
    f_lower: float
    f_upper: float
    f_bound_method: str
    transforms: tuple[LocationTransform, ...] = ()
    names: tuple[str, ...] = ()
    invariant_G: np.ndarray = field(default=None, repr=False)
    invariant_g: np.ndarray = field(default=None, repr=False)
    invariant_starts: tuple[int, ...] = field(default=(), repr=False)

    # ------------------------------------------------------------------ coordinates
    @property
    def n(self) -> int:
        return self.T.shape[0]

    @property
    def n_locations(self) -> int:
        return self.automaton.n_locations

    @property
    def is_affine(self) -> bool:
        return self.alpha is not None

    @property
    def is_identity(self) -> bool:
        return bool(np.array_equal(self.T, np.eye(self.n)) and not np.any(self.d))

    def to_z(self, x) -> np.ndarray:
        """``z = T x + d`` for one state ``(n,)`` or many ``(N, n)``.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            Original state(s).

        Returns
        -------
        ndarray
            The canonical coordinates, shaped like ``x``.
        """
        return np.asarray(x, dtype=float) @ self.T.T + self.d

    def to_x(self, z) -> np.ndarray:
        """``x = T_inv (z - d)`` for one state ``(n,)`` or many ``(N, n)``.

        Parameters
        ----------
        z : (n,) or (N, n) array_like
            Canonical state(s).

        Returns
        -------
        ndarray
            The original coordinates, shaped like ``z``.
        """
        return (np.asarray(z, dtype=float) - self.d) @ self.T_inv.T

    # ------------------------------------------------------------------ dynamics in z
    def f(self, q: int, z) -> float:
        """``z_n' = f_q(z)``, the last line of form (4) in location ``q``.

        Parameters
        ----------
        q : int
            0-based location index.
        z : (n,) array_like
            Canonical state.

        Returns
        -------
        float
            The value of the last line of form (4).
        """
        z = np.asarray(z, dtype=float)
        if self.alpha is not None:
            return float(self.alpha[q] @ z + self.beta[q])
        loc = self.automaton.locations[q]
        return float(np.asarray(loc.flow(self.to_x(z), np.zeros(self.automaton.m)), dtype=float).reshape(-1)[-1])

    def mode_of(self, z) -> int:
        """Location whose invariant contains ``x = T_inv (z - d)`` (the mode function of eq. 5).

        Total: a point outside every invariant (an estimate in a gap between regions) gets the
        location it violates least, so the runtime observer never raises here.

        Parameters
        ----------
        z : (n,) array_like
            Canonical state.

        Returns
        -------
        int
            0-based location index.
        """
        v = self.invariant_G @ np.asarray(z, dtype=float) - self.invariant_g
        best, best_v = 0, np.inf
        for q in range(len(self.invariant_starts) - 1):
            a, b = self.invariant_starts[q], self.invariant_starts[q + 1]
            worst = float(v[a:b].max()) if b > a else -np.inf
            if worst <= 0.0:
                return q
            if worst < best_v:
                best, best_v = q, worst
        return best

    def modes_of(self, Z) -> np.ndarray:
        """:meth:`mode_of` for every row of ``Z`` ``(N, n)`` (vectorised).

        Parameters
        ----------
        Z : (N, n) array_like
            Canonical states, one per row (a single ``(n,)`` state is taken as one row).

        Returns
        -------
        (N,) int ndarray
            0-based location index of each row.
        """
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        V = Z @ self.invariant_G.T - self.invariant_g
        L = len(self.invariant_starts) - 1
        worst = np.full((Z.shape[0], L), -np.inf)
        for q in range(L):
            a, b = self.invariant_starts[q], self.invariant_starts[q + 1]
            if b > a:
                worst[:, q] = V[:, a:b].max(axis=1)
        inside = worst <= 0.0
        first = np.argmax(inside, axis=1)
        return np.where(inside.any(axis=1), first, np.argmin(worst, axis=1))

    def sigma(self, z) -> np.ndarray:
        """Values of every switching function at ``z`` (``(k,)``, or ``(N, k)`` for ``(N, n)``).

        Parameters
        ----------
        z : (n,) or (N, n) array_like
            Canonical state(s).

        Returns
        -------
        ndarray
            The switching functions' values.
        """
        z = np.asarray(z, dtype=float)
        rows = np.array([s.z_row for s in self.switching]).reshape(-1, self.n)
        offs = np.array([s.z_offset for s in self.switching])
        return z @ rows.T + offs

    def describe(self) -> dict:
        """JSON-ready summary (coordinates, ``P_q``, switching functions, ranges).

        Returns
        -------
        dict
            The summary.
        """
        out = {
            "T": self.T.tolist(),
            "d": self.d.tolist(),
            "names": list(self.names),
            "z_lower": self.z_lower.tolist(),
            "z_upper": self.z_upper.tolist(),
            "f_range": [self.f_lower, self.f_upper],
            "f_bound_method": self.f_bound_method,
            "switching": [
                {"x_row": s.x_row.tolist(), "z_row": s.z_row.tolist(), "z_offset": s.z_offset, "thresholds": list(s.thresholds)}
                for s in self.switching
            ],
        }
        if self.alpha is not None:
            out["P"] = {
                self.automaton.locations[q].name: {"alpha": self.alpha[q].tolist(), "beta": float(self.beta[q])}
                for q in range(self.n_locations)
            }
        return out


# ---------------------------------------------------------------------------------- helpers
def observability_matrix(A, C) -> np.ndarray:
    """``[C; C A; ...; C A^{n-1}]`` (the codistribution of Assumption 1b, paper 001, for linear flows).

    Parameters
    ----------
    A : (n, n) array_like
        State matrix.
    C : (p, n) or (n,) array_like
        Output matrix (a vector is one output row).

    Returns
    -------
    (n p, n) ndarray
        The blocks ``C A^k``, ``k = 0 ... n-1``, stacked.

    See Also
    --------
    observability_form : the coordinates built from it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.systems import observability_matrix
    >>> A, C = np.array([[0.0, 1.0], [-2.0, -3.0]]), np.array([[1.0, 0.0]])
    >>> observability_matrix(A, C)
    array([[1., 0.],
           [0., 1.]])
    """
    A = np.asarray(A, dtype=float)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    rows, R = [], C
    for _ in range(A.shape[0]):
        rows.append(R)
        R = R @ A
    return np.vstack(rows)


def _box(automaton: HybridAutomaton) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = automaton.state_bounds.bounding_box()
    return lo, hi


def _scaled_rank(M: np.ndarray, scale: np.ndarray) -> int:
    s = np.linalg.svd(M * scale[None, :], compute_uv=False)
    if s.size == 0 or s[0] == 0.0:
        return 0
    return int(np.sum(s > RANK_RTOL * s[0] * max(M.shape)))


def _affine_output(automaton: HybridAutomaton) -> tuple[np.ndarray, float]:
    """The common output ``y = C x + c`` (one output, no feedthrough, same in every location)."""
    if automaton.p != 1:
        raise ModelError("automaton.p", "one measured output (form (4) of paper 001 has y = z1)", f"{automaton.p} outputs")
    C0 = c0 = None
    for q, loc in enumerate(automaton.locations):
        if loc.C is None:
            raise ModelError(f"locations[{q}] ({loc.name}).output", "an affine output y = C x + c", "a callable output")
        if automaton.m and np.any(loc.D):
            raise ModelError(f"locations[{q}] ({loc.name}).D", "no feedthrough (the observer of paper 001 is autonomous)", "D != 0")
        C, c = loc.C[0], float(loc.c[0])
        if C0 is None:
            C0, c0 = C, c
        elif not (np.allclose(C, C0, rtol=CANONICAL_FORM_RTOL, atol=0) and np.isclose(c, c0, rtol=CANONICAL_FORM_RTOL, atol=0)):
            raise ModelError(f"locations[{q}] ({loc.name}).C", "the same output map in every location", f"{C.tolist()} + {c}")
    return np.asarray(C0), float(c0)


def location_transforms(automaton: HybridAutomaton) -> tuple[LocationTransform, ...]:
    """Observability coordinates of every affine location, computed separately (Section 2, paper 001).

    This is the transformation that is "computed and reported" when the locations do not share
    one set of coordinates: each ``(T_q, d_q)`` puts location ``q`` alone in form (2)/(3).

    Parameters
    ----------
    automaton : HybridAutomaton
        Model with affine, input-free locations and one common affine output ``y = C x + c``.

    Returns
    -------
    tuple of LocationTransform
        One per location, in location order.

    Raises
    ------
    ModelError
        If a location is not affine, has an input, or the output is not a single affine map.

    See Also
    --------
    LocationTransform : what it returns, one per location.
    observability_form : one set of coordinates for all locations.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import location_transforms
    >>> transforms = location_transforms(chua)
    >>> [(t.name, t.rank) for t in transforms]           # every location observable from y
    [('q1', 3), ('q2', 3), ('q3', 3)]
    """
    C, c = _affine_output(automaton)
    lo, hi = _box(automaton)
    scale = np.maximum(0.5 * (hi - lo), np.finfo(float).tiny)
    n = automaton.n
    out = []
    for q, loc in enumerate(automaton.locations):
        if loc.A is None:
            raise ModelError(f"locations[{q}] ({loc.name}).flow", "an affine flow x' = A x + E", "a callable flow")
        if automaton.m and np.any(loc.B):
            raise ModelError(f"locations[{q}] ({loc.name}).B", "no input (form (4) of paper 001 is autonomous)", "B != 0")
        A, E = loc.A, loc.E
        T = observability_matrix(A, C)
        d = np.empty(n)
        d[0] = c
        CAk = C.copy()  # C A^{k-1}
        for k in range(1, n):
            d[k] = float(CAk @ E)
            CAk = CAk @ A
        rank = _scaled_rank(T, scale)
        alpha = beta = None
        if rank == n:
            CAn = C @ np.linalg.matrix_power(A, n)
            alpha = np.linalg.solve(T.T, CAn)  # alpha = C A^n T^{-1}
            beta = float(C @ np.linalg.matrix_power(A, n - 1) @ E - alpha @ d)
        out.append(LocationTransform(q, loc.name, T, d, rank, alpha, beta))
    return tuple(out)


def _interval(row: np.ndarray, const: float, lo: np.ndarray, hi: np.ndarray) -> tuple[float, float]:
    """Exact range of ``row . x + const`` over the box ``[lo, hi]``."""
    c, r = 0.5 * (lo + hi), 0.5 * (hi - lo)
    mid = float(row @ c + const)
    rad = float(np.abs(row) @ r)
    return mid - rad, mid + rad


def _switching_functions(automaton: HybridAutomaton, T_inv: np.ndarray, d: np.ndarray) -> tuple[SwitchingFunction, ...]:
    n = automaton.n
    found: list[tuple[np.ndarray, list[float]]] = []
    for loc in automaton.locations:
        inv = loc.invariant
        for a, b in zip(inv.A[:, :n], inv.b):
            m = np.max(np.abs(a))
            if m == 0.0:
                continue
            a, b = a / m, b / m
            first = a[np.nonzero(np.abs(a) > 0)[0][0]]
            if first < 0:  # a x <= b  <=>  (-a) x >= -b: the same function, threshold -b
                a, b = -a, -b
            for row, thr in found:
                if np.allclose(row, a, rtol=CANONICAL_FORM_RTOL, atol=CANONICAL_FORM_RTOL):
                    if not any(np.isclose(b, t, rtol=CANONICAL_FORM_RTOL, atol=CANONICAL_FORM_RTOL) for t in thr):
                        thr.append(float(b))
                    break
            else:
                found.append((a, [float(b)]))
    out = []
    for row, thr in found:
        z_row = row @ T_inv
        out.append(SwitchingFunction(row, z_row, float(-z_row @ d) + 0.0, tuple(sorted(t + 0.0 for t in thr))))
    return tuple(out)


def _invariant_table(automaton: HybridAutomaton, T_inv: np.ndarray, d: np.ndarray, zscale: np.ndarray):
    """Invariant rows rewritten in ``z`` (``G z <= g``), unit-norm in box-scaled ``z``, with a slack."""
    n = automaton.n
    rows, rhs, starts = [], [], [0]
    for loc in automaton.locations:
        A = loc.invariant.A[:, :n]
        b = loc.invariant.b
        G = A @ T_inv
        g = b + G @ d
        norm = np.linalg.norm(G * zscale[None, :], axis=1)
        norm = np.where(norm > 0, norm, 1.0)
        rows.append(G / norm[:, None])
        # same relative slack as Polytope.contains, so ties on a boundary resolve by location order
        rhs.append(g / norm + MEMBERSHIP_RTOL * (1.0 + np.abs(g / norm)))
        starts.append(starts[-1] + A.shape[0])
    return np.vstack(rows), np.concatenate(rhs), tuple(starts)


def _last_component(loc, X: np.ndarray, u: np.ndarray, n: int) -> np.ndarray:
    """``flow(x)[n-1]`` for every row of ``X``: one vectorised call when the flow accepts ``(n, N)``."""
    try:
        out = np.asarray(loc.flow(X.T, u), dtype=float)
        if out.shape == (n, X.shape[0]):
            return out[n - 1]
    except (TypeError, ValueError, IndexError):
        pass
    return np.array([float(np.asarray(loc.flow(x, u), dtype=float).reshape(-1)[n - 1]) for x in X])


def _check_triangular(automaton: HybridAutomaton, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Check form (4) on samples of the box; return the sampled values of ``f_q`` (``(L, N)``)."""
    n, m = automaton.n, automaton.m
    X = lo + (hi - lo) * rng.random((DERIVATIVE_BOUND_SAMPLES, n))
    corners = np.array(np.meshgrid(*[(a, b) for a, b in zip(lo, hi)], indexing="ij")).reshape(n, -1).T
    X = np.vstack([corners, X])
    u = np.zeros(m)
    scale = np.maximum(np.abs(lo), np.abs(hi))
    check = X[:: max(1, X.shape[0] // TRIANGULAR_CHECK_SAMPLES)]
    for q, loc in enumerate(automaton.locations):
        for x in check:
            y = automaton.output(q, x, u)
            if abs(float(y[0]) - x[0]) > TRIANGULAR_CHECK_RTOL * (1.0 + scale[0]):
                raise ModelError(
                    f"locations[{q}] ({loc.name}).output",
                    "y = x1 (the canonical form (4) of paper 001), or affine locations whose form can be computed",
                    f"y = {float(y[0]):.6g} at x = {np.round(x, 6).tolist()}",
                )
            dx = automaton.flow(q, x, u)
            for k in range(n - 1):
                if abs(dx[k] - x[k + 1]) > TRIANGULAR_CHECK_RTOL * (1.0 + scale[k + 1]):
                    raise ModelError(
                        f"locations[{q}] ({loc.name}).flow",
                        f"the triangular form (4) of paper 001: {automaton.state_names[k]}' = {automaton.state_names[k + 1]}"
                        " (or affine locations, whose observability form is computed)",
                        f"{automaton.state_names[k]}' = {dx[k]:.6g} at x = {np.round(x, 6).tolist()}",
                    )
    return np.array([_last_component(loc, X, u, n) for loc in automaton.locations])


# ---------------------------------------------------------------------------------- main entry
def observability_form(automaton: HybridAutomaton, *, seed: int = 0) -> ObservabilityForm:
    """Bring ``automaton`` into the canonical form (4) of paper 001.

    Affine automata: the coordinates ``z = T x + d`` (output and its derivatives) are computed from
    ``(A_q, E_q, C)``; every location must be observable (Assumption 1b) and share the coordinates.
    Automata with callable flows must already be in form (4) (checked on samples).

    Parameters
    ----------
    automaton : HybridAutomaton
        Autonomous, one output.
    seed : int
        Seed of the box samples used for callable flows (triangularity check and the range of
        ``f_q``).

    Returns
    -------
    ObservabilityForm

    Raises
    ------
    ModelError
        A location is not observable (names the location and the rank), the locations do not share
        observability coordinates (the per-location transformations are reported in the message,
        see :func:`location_transforms`), the flow is not triangular, or the system has inputs or
        several outputs.

    See Also
    --------
    ObservabilityForm : what it returns.
    location_transforms : one transform per location.
    hybobs_opt.observers.SlidingModeObserver : the observer (5) that uses it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(chua)
    >>> form.n, form.n_locations, form.T.shape            # z = T x + d: y and its derivatives
    (3, 3, (3, 3))
    >>> form.switching[0].thresholds                     # the locations change at x1 = -1 and 1
    (-1.0, 1.0)
    """
    if not isinstance(automaton, HybridAutomaton):
        raise ModelError("automaton", "a HybridAutomaton", type(automaton).__name__)
    n = automaton.n
    lo, hi = _box(automaton)
    if automaton.m and any(loc.B is None or np.any(loc.B) for loc in automaton.locations):
        raise ModelError("automaton.input_bounds", "an autonomous automaton (form (4) of paper 001 has no input)", f"m = {automaton.m}")
    if all(loc.A is not None and loc.C is not None for loc in automaton.locations):
        trs = location_transforms(automaton)
        for tr in trs:
            if not tr.observable:
                raise ModelError(
                    f"locations[{tr.location}] ({tr.name})",
                    f"an observable subsystem: rank [C; CA; ...; CA^{n - 1}] = {n} (Assumption 1b of paper 001)",
                    f"rank {tr.rank}",
                )
        ref = trs[0]
        size = np.maximum(np.abs(ref.T).max(), 1.0)
        for tr in trs[1:]:
            same_T = np.allclose(tr.T, ref.T, rtol=0, atol=CANONICAL_FORM_RTOL * size)
            same_d = np.allclose(tr.d, ref.d, rtol=0, atol=CANONICAL_FORM_RTOL * max(1.0, np.abs(ref.d).max()))
            if not (same_T and same_d):
                k = int(np.argmax(np.abs(tr.T - ref.T).max(axis=1) + np.abs(tr.d - ref.d)))
                report = "; ".join(f"{t.name}: T = {np.round(t.T, 6).tolist()}, d = {np.round(t.d, 6).tolist()}" for t in trs)
                raise ModelError(
                    "locations",
                    "one set of observability coordinates for all locations (C A_q^k and C A_q^(k-1) E_q equal for "
                    "k < n), as form (4) of paper 001 requires",
                    f"row z{k + 1} differs between {ref.name} and {tr.name}; per-location transformations z = T x + d: {report}",
                )
        T, d = ref.T.copy(), ref.d.copy()
        T_inv = np.linalg.inv(T)
        alpha = np.array([tr.alpha for tr in trs])
        beta = np.array([tr.beta for tr in trs])
        zl, zu = np.empty(n), np.empty(n)
        for k in range(n):
            zl[k], zu[k] = _interval(T[k], d[k], lo, hi)
        C, _ = _affine_output(automaton)
        fl, fu = np.inf, -np.inf
        for q, loc in enumerate(automaton.locations):
            CAn1 = C @ np.linalg.matrix_power(loc.A, n - 1)
            a, b = _interval(CAn1 @ loc.A, float(CAn1 @ loc.E), lo, hi)  # z_n' = C A^n x + C A^{n-1} E
            fl, fu = min(fl, a), max(fu, b)
        method = "interval"
        transforms = trs
    else:
        T, T_inv, d = np.eye(n), np.eye(n), np.zeros(n)
        values = _check_triangular(automaton, lo, hi, np.random.default_rng(seed))
        if not np.all(np.isfinite(values)):
            raise ModelError("locations.flow", "finite values on the operating box", "NaN or Inf")
        vmin, vmax = float(values.min()), float(values.max())
        widen = DERIVATIVE_BOUND_MARGIN * max(vmax - vmin, 1e-300)
        fl, fu = vmin - widen, vmax + widen
        zl, zu = lo.copy(), hi.copy()
        alpha = beta = None
        method = "sampled"
        transforms = ()
    identity = np.array_equal(T, np.eye(n)) and not np.any(d)
    names = tuple(automaton.state_names) if identity else tuple(f"z{k + 1}" for k in range(n))
    zscale = np.maximum(0.5 * (zu - zl), np.finfo(float).tiny)
    G, g, starts = _invariant_table(automaton, T_inv, d, zscale)
    return ObservabilityForm(
        automaton=automaton, T=T, T_inv=T_inv, d=d, alpha=alpha, beta=beta,
        switching=_switching_functions(automaton, T_inv, d), z_lower=zl, z_upper=zu,
        f_lower=float(fl), f_upper=float(fu), f_bound_method=method, transforms=transforms, names=names,
        invariant_G=G, invariant_g=g, invariant_starts=starts,
    )


# ---------------------------------------------------------------------------------- Theorem 1
@dataclass(frozen=True)
class Theorem1Result:
    """Theorem 1 of paper 001 for two affine locations ``i``, ``j`` (sufficient conditions).

    ``v`` are the output derivatives ``(y, y', ..., y^{(n-1)})``; ``g_q(v) = alpha_q . v + beta_q``
    and ``sigma_q(v)`` are location ``q``'s last dynamics and switching functions in its own
    coordinates.

    Parameters
    ----------
    i, j : int
    M_dim : int
        Dimension of ``M = {v : g_i(v) = g_j(v)}``: ``-1`` empty, ``n - 1`` hyperplane, ``n`` all.
    M_discrete : bool
        ``M`` is a discrete set (empty or a point): item (i).
    nontransverse_dim : int
        Dimension of the part of ``M`` where the flows are tangent to ``M`` (``-1`` none); item
        (ii) needs it to be discrete (``<= 0``).
    S_dim : int
        Dimension of ``S = {v : sigma_i(v) = sigma_j(v)}`` for every switching function; item
        (iii) needs ``S = R^n`` (``S_dim = n``).
    L_dim : int
        Dimension of the set ``L`` of common equilibria (``-1`` empty).
    L_point : (n,) array or None
        A point of ``L``.
    sigma_L_one_sided : bool
        Every switching function is constant on ``L`` (so ``L`` lies on one side of the switch).
    items : dict
        ``{"i": bool, "ii": bool, "iii": bool}``: which item of Theorem 1 applies.
    observable : bool or None
        ``True`` when some item applies; ``None`` when none does (the theorem is only sufficient).

    See Also
    --------
    theorem1 : computes it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import theorem1
    >>> result = theorem1(chua, 0, 1)
    >>> sorted(result.items)                             # the conditions, each with its verdict
    ['i', 'ii', 'iii']
    >>> result.observable
    True
    """

    i: int
    j: int
    M_dim: int
    M_discrete: bool
    nontransverse_dim: int
    S_dim: int
    L_dim: int
    L_point: np.ndarray | None
    sigma_L_one_sided: bool
    items: dict
    observable: bool | None

    def to_dict(self) -> dict:
        """JSON-ready record of the conditions and the verdict.

        Returns
        -------
        dict
            Every field of the result, ``L_point`` as a list (or ``None``).
        """
        return {
            "i": self.i, "j": self.j, "M_dim": self.M_dim, "M_discrete": self.M_discrete,
            "nontransverse_dim": self.nontransverse_dim, "S_dim": self.S_dim, "L_dim": self.L_dim,
            "L_point": None if self.L_point is None else self.L_point.tolist(),
            "sigma_L_one_sided": self.sigma_L_one_sided, "items": dict(self.items), "observable": self.observable,
        }


def _affine_set_dim(E: np.ndarray, e: np.ndarray, scale: float) -> tuple[int, np.ndarray | None]:
    """Dimension of ``{v : E v = e}`` (``-1`` if empty) and one point of it; ``scale`` is the size of ``E``'s entries."""
    n = E.shape[1]
    if E.shape[0] == 0:
        return n, np.zeros(n)
    v, *_ = np.linalg.lstsq(E, e, rcond=None)
    if np.linalg.norm(E @ v - e) > CANONICAL_FORM_RTOL * scale * (1.0 + np.linalg.norm(e)):
        return -1, None
    s = np.linalg.svd(E, compute_uv=False)
    # rows that are rounding noise of an exact zero (e.g. two equal coordinate maps) carry no rank
    floor = max(RANK_RTOL * float(s[0]) * max(E.shape), CANONICAL_FORM_RTOL * scale) if s.size else 0.0
    r = int(np.sum(s > floor))
    return n - r, v


def theorem1(automaton: HybridAutomaton, i: int, j: int) -> Theorem1Result:
    """Evaluate the conditions of Theorem 1 (paper 001) for affine locations ``i`` and ``j``.

    - ``M = {v : g_i(v) = g_j(v)}`` is an affine set (``(alpha_i - alpha_j) . v = beta_j - beta_i``).
    - The flows ``F_q(v) = (v2, ..., vn, g_q(v))`` agree on ``M``; they are tangent to ``M`` where
      ``delta . F(v) = 0`` with ``delta = alpha_i - alpha_j``, an affine condition, so the
      non-transverse part of ``M`` is an affine set whose dimension is computed.
    - ``S = {v : sigma(T_i^{-1}(v - d_i)) = sigma(T_j^{-1}(v - d_j))}`` for every switching function
      (``R^n`` when both locations share the coordinates).
    - ``L = {x : A_i x + E_i = 0 = A_j x + E_j}``, and whether every ``sigma`` is constant on it.

    Parameters
    ----------
    automaton : HybridAutomaton
        Model with affine, input-free locations and one common affine output.
    i, j : int
        0-based indices of the two locations.

    Returns
    -------
    Theorem1Result
        Each condition of Theorem 1 with its verdict, and ``observable`` (``True`` when the
        sufficient conditions hold, ``None`` when they do not decide).

    Raises
    ------
    ModelError
        If a location is not affine or not observable (Assumption 1b).

    See Also
    --------
    theorem1_pairs : every pair joined by an edge.
    Theorem1Result : what it returns.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import theorem1
    >>> result = theorem1(chua, 0, 1)
    >>> result.observable, result.M_dim, result.S_dim
    (True, 2, 3)
    """
    trs = location_transforms(automaton)
    L = len(trs)
    for k in (i, j):
        if not (isinstance(k, (int, np.integer)) and 0 <= k < L):
            raise ModelError("location index", f"an index in 0..{L - 1}", repr(k))
    ti, tj = trs[i], trs[j]
    for t in (ti, tj):
        if not t.observable:
            raise ModelError(f"locations[{t.location}] ({t.name})", "an observable subsystem (Assumption 1b)", f"rank {t.rank}")
    n = automaton.n
    size = max(1.0, float(np.abs(ti.alpha).max()), float(np.abs(tj.alpha).max()))
    delta = ti.alpha - tj.alpha
    if np.abs(delta).max() <= CANONICAL_FORM_RTOL * size:
        same = np.isclose(ti.beta, tj.beta, rtol=0, atol=CANONICAL_FORM_RTOL * max(size, abs(ti.beta), abs(tj.beta)))
        M_dim = n if same else -1  # identical last dynamics, or parallel ones that never meet
    else:
        M_dim = n - 1  # the hyperplane delta . v = beta_j - beta_i
    M_discrete = M_dim <= 0
    # tangency: delta . F(v) = sum_{k<n} delta_k v_{k+1} + delta_n (alpha_i . v + beta_i) = 0 on M
    if M_dim == -1 or M_dim == n:
        nt_dim = -1  # no M, or g_i = g_j (the subsystems coincide): nothing to be transverse to
    elif M_dim == 0:
        nt_dim = 0
    else:
        a = np.zeros(n)
        a[1:] = delta[:-1]
        a = a + delta[-1] * ti.alpha
        nt_dim, _ = _affine_set_dim(np.vstack([delta, a]), np.array([tj.beta - ti.beta, -delta[-1] * ti.beta]), size)
    # S: each switching function written in each location's own coordinates v = T_q x + d_q
    sw = _switching_functions(automaton, np.eye(n), np.zeros(n))
    Ti_inv, Tj_inv = np.linalg.inv(ti.T), np.linalg.inv(tj.T)
    rows, rhs = [], []
    for s in sw:
        ri, rj = s.x_row @ Ti_inv, s.x_row @ Tj_inv
        rows.append(ri - rj)
        rhs.append(float(ri @ ti.d - rj @ tj.d))
    S_dim, _ = _affine_set_dim(np.array(rows).reshape(-1, n), np.array(rhs), size)
    # L: common equilibria
    Ai, Aj = automaton.locations[i].A, automaton.locations[j].A
    Ei, Ej = automaton.locations[i].E, automaton.locations[j].E
    Astack = np.vstack([Ai, Aj])
    L_dim, L_point = _affine_set_dim(Astack, -np.concatenate([Ei, Ej]), max(1.0, float(np.abs(Astack).max())))
    one_sided = True
    if L_dim > 0:
        _, sv, Vt = np.linalg.svd(Astack)
        r = n - L_dim
        N = Vt[r:].T
        one_sided = all(np.abs(s.x_row @ N).max() <= CANONICAL_FORM_RTOL * np.abs(s.x_row).max() for s in sw)
    items = {
        "i": bool(M_discrete and one_sided),
        "ii": bool(nt_dim <= 0 and one_sided),
        "iii": bool(S_dim == n),
    }
    return Theorem1Result(i, j, int(M_dim), bool(M_discrete), int(nt_dim), int(S_dim), int(L_dim), L_point,
                          bool(one_sided), items, True if any(items.values()) else None)


def theorem1_pairs(automaton: HybridAutomaton) -> list[Theorem1Result]:
    """:func:`theorem1` for every pair of locations joined by an edge of the location graph.

    Parameters
    ----------
    automaton : HybridAutomaton
        Model with affine locations; without edges between distinct locations every pair of
        locations is evaluated.

    Returns
    -------
    list of Theorem1Result
        One per pair of locations joined by an edge.

    See Also
    --------
    theorem1 : one pair.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> chua = get_example("double_scroll").build()                # Example 3 of paper 001
    >>> from hybobs_opt.systems import theorem1_pairs
    >>> [(r.i, r.j, r.observable) for r in theorem1_pairs(chua)]
    [(0, 1, True), (1, 2, True)]
    """
    pairs = sorted({tuple(sorted((e.source, e.target))) for e in automaton.edges if e.source != e.target})
    if not pairs:
        pairs = list(combinations(range(automaton.n_locations), 2))
    return [theorem1(automaton, i, j) for i, j in pairs]
