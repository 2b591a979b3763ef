"""Results that hold for every observer gain: undetectable points and indistinguishable mirror states.

The LMIs of :mod:`.hierarchy` are sufficient conditions: their infeasibility rules out a class of
Lyapunov proofs, not the gains themselves.  Two properties of the system rule out more:

* **Undetectable points.**  At a state ``x*`` where the frozen linearisation ``(J(x*), C(x*))``,
  ``J = A + F diag(f'(E x)) E``, ``C = diag(h'(C x)) C``, has an eigenvalue ``lambda`` with
  ``Re lambda >= 0`` whose eigenvector ``v`` the outputs do not see (``C(x*) v = 0``; the
  Popov-Belevitch-Hautus test), ``(J - L C) v = lambda v`` for *every* gain ``L``.  Since ``J(x*)``
  lies in the box of Jacobian slopes of every region containing ``x*``, no constant, switched or
  time-varying gain satisfies any of the quadratic conditions of :mod:`.hierarchy` on such a region;
  and when ``x*`` is an equilibrium the error of the observer (6) cannot converge exponentially
  for the trajectory resting there, whatever the gain.  Such points are found by sampling the
  range and by root finding on the output slopes ``h_j'`` (where ``C(x)`` loses rank).
* **Indistinguishable states.**  An affine involution ``T x = c + S (x - c)`` (``S`` a diagonal
  sign matrix) with ``S f(x, u) = f(T x, u)`` (the vector field is ``T``-equivariant) and
  ``h(T x) = h(x)`` maps every trajectory onto one with identical outputs for every input and for
  all time: ``x`` and ``T x`` cannot be told apart by any observer (even output functions of a
  mirror-symmetric plant, such as a pendulum measured through ``cos(theta)``).

Both are evaluated numerically at the system's functions (the equivariance at random points to a
relative tolerance); ``verify()`` re-evaluates them without the search.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..defaults import DETECTABILITY_SAMPLES, MAX_SYMMETRY_CANDIDATES, SYMMETRY_POINTS
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import EIGEN_DECAY_RTOL, EQUILIBRIUM_RTOL, PBH_RTOL, SYMMETRY_RTOL
from .bounds import slope_change_points
from .schedule import coordinate_index, make_region
from ..results import Certificate


def _fmt_complex(lam: complex) -> str:
    return f"{lam.real:.4g}" if abs(lam.imag) < 1e-12 else f"{lam.real:.4g}{lam.imag:+.4g}i"


# ---------------------------------------------------------------------------- undetectable points
@dataclass(frozen=True)
class UndetectablePoint(Certificate):
    """A state where the linearisation has a non-decaying mode the outputs do not see.

    Parameters
    ----------
    x : array
        The state (the scheduling coordinate at ``s``, the other states at the centre of the box).
    coordinate : int
    s : float
        The scheduling value.
    eigenvalue : complex
        ``lambda`` of ``J(x)`` with ``Re lambda >= 0`` and ``C(x) v = 0``.
    mode : array
        Its eigenvector ``v`` (unit norm).
    equilibrium : bool
        ``x`` is an equilibrium of the unforced system (``||x'|| <= EQUILIBRIUM_RTOL (1 + ||x||)`` at ``u = 0``).
    pbh_residual : float
        ``sigma_min([J - lambda I; C])`` relative to ``1 + ||J|| + ||C||``.
    system : ScalarNonlinearSystem
        The system.

    See Also
    --------
    undetectable_points : Finds them.
    OutputSymmetry : A global obstruction of the same kind.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A rotation measured through ``cos(x1)``: the output cannot tell ``x`` from ``-x``.

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("x1", "x2"))
    >>> import casadi as ca
    >>> cosine = ScalarFunction("cos", ca.cos, lambda z: -ca.sin(z))   # CasADi expressions
    >>> system = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [-1.0, 0.0]], C=[[1.0, 0.0]], h=(cosine,),
    ...                                name="mirror")
    >>> from hybobs_opt.lmi import undetectable_points
    >>> point = undetectable_points(system, "x1")[0]
    >>> np.round(point.x, 6), point.s
    (array([0., 0.]), 0.0)
    >>> point.verify()
    True
    """

    system: ScalarNonlinearSystem = field(repr=False)
    x: np.ndarray
    coordinate: int
    s: float
    eigenvalue: complex
    mode: np.ndarray
    equilibrium: bool
    pbh_residual: float

    def verify(self) -> bool:
        """Re-evaluate ``J v = lambda v``, ``C v = 0``, ``Re lambda >= 0`` at ``x`` (numpy).

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        J = self.system.dynamics_jacobian(self.x)
        C = self.system.output_jacobian(self.x)
        v = np.asarray(self.mode, dtype=complex)
        scale = 1.0 + np.linalg.norm(J, 2) + np.linalg.norm(C, 2)
        tol = 1e3 * PBH_RTOL * scale
        return bool(np.linalg.norm(J @ v - self.eigenvalue * v) <= tol and np.linalg.norm(C @ v) <= tol
                    and self.eigenvalue.real >= -EIGEN_DECAY_RTOL * scale)

    @property
    def reason(self) -> str:
        """The certificate's statement (:attr:`claim`)."""
        return self.claim

    @property
    def claim(self) -> str:
        name = self.system.state_names[self.coordinate]
        kind = "unstable" if self.eigenvalue.real > EIGEN_DECAY_RTOL * (1 + np.linalg.norm(self.system.dynamics_jacobian(self.x), 2)) else "marginal"
        text = (f"At {name} = {self.s:.6g} the linearisation has the {kind} eigenvalue {_fmt_complex(self.eigenvalue)} "
                f"whose mode the outputs do not see (C(x) v = 0): the frozen error dynamics J - L C keep it for every "
                f"gain L, so no constant, switched or time-varying gain satisfies a quadratic Lyapunov condition on any "
                f"region containing this point")
        if self.equilibrium:
            text += (", and since it is an equilibrium, no observer gain of the form (6) makes the error converge "
                     "exponentially for the trajectory resting there")
        return text + "."

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"coordinate": self.system.state_names[self.coordinate], "s": self.s, "x": self.x.tolist(),
                "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag], "mode": np.real(self.mode).tolist(),
                "equilibrium": self.equilibrium, "pbh_residual": self.pbh_residual, "verified": self.verify(),
                "claim": self.claim}


def _undetectable_mode(J: np.ndarray, C: np.ndarray):
    """``(lambda, v, residual)`` of the least observable non-decaying eigenvalue, or ``None``."""
    n = J.shape[0]
    scale = 1.0 + np.linalg.norm(J, 2) + np.linalg.norm(C, 2)
    best = None
    for lam in np.linalg.eigvals(J):
        if lam.real < -EIGEN_DECAY_RTOL * scale:
            continue
        M = np.vstack([J - lam * np.eye(n), C.astype(complex)])
        _, sv, vh = np.linalg.svd(M)
        res = float(sv[-1]) / scale
        if res <= PBH_RTOL and (best is None or res < best[2]):
            best = (complex(lam), vh[-1].conj(), res)
    return best


def undetectable_points(system: ScalarNonlinearSystem, coordinate: int | str, lo: float | None = None,
                        hi: float | None = None, *, samples: int = DETECTABILITY_SAMPLES) -> list[UndetectablePoint]:
    """Points of ``[lo, hi]`` (along ``coordinate``) where the linearisation is not detectable.

    The other states sit at the centre of the operating box (exact when, as in the paper's
    examples, the functions depend on the scheduling coordinate alone).  Candidates: the range
    ends, ``samples`` grid points, and the roots of every output slope ``h_j'(C_j x)`` along the
    coordinate (refined by ``brentq``: the points where an output stops seeing the state).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    coordinate : int or str
        The scheduling state (index or name).
    lo, hi : float, optional
        The range in model units (default: the operating box).
    samples : int, default DETECTABILITY_SAMPLES
        Number of grid points (:data:`~hybobs_opt.defaults.DETECTABILITY_SAMPLES`).

    Returns
    -------
    list of UndetectablePoint
        The points found, each with the non-decaying eigenvalue, its mode and the PBH residual that
        shows the outputs do not see it (empty when the linearisation is detectable everywhere).

    Raises
    ------
    ModelError
        If the range is empty, reversed or outside the box.

    See Also
    --------
    UndetectablePoint : One point and its re-check.
    output_symmetries : Global mirror maps the outputs cannot detect.
    diagnose : Reports these points with the LMI's verdict.

    Examples
    --------
    ``cos(x1)`` is flat at ``x1 = 0``: there the output does not see the rotation.

    >>> import numpy as np
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A rotation measured through ``cos(x1)``: the output cannot tell ``x`` from ``-x``.

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("x1", "x2"))
    >>> import casadi as ca
    >>> cosine = ScalarFunction("cos", ca.cos, lambda z: -ca.sin(z))   # CasADi expressions
    >>> system = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [-1.0, 0.0]], C=[[1.0, 0.0]], h=(cosine,),
    ...                                name="mirror")
    >>> from hybobs_opt.lmi import undetectable_points
    >>> points = undetectable_points(system, "x1")
    >>> [round(p.s, 6) for p in points], points[0].verify()
    ([0.0], True)
    """
    k = coordinate_index(system, coordinate)
    lo = float(system.box_lower[k]) if lo is None else float(lo)
    hi = float(system.box_upper[k]) if hi is None else float(hi)
    make_region(system, k, lo, hi)  # validates the range
    centre = 0.5 * (system.box_lower + system.box_upper)
    cand = [lo, hi, *np.linspace(lo, hi, max(int(samples), 2)).tolist()]
    for row, fn in zip(system.C, system.h):
        if row[k] == 0 or fn.is_identity:
            continue
        offset = float(row @ centre - row[k] * centre[k])
        a, b = sorted((offset + row[k] * lo, offset + row[k] * hi))
        cand += [(z - offset) / row[k] for z in slope_change_points(fn, a, b)]
    out: list[UndetectablePoint] = []
    for s in sorted(set(cand)):
        x = centre.copy()
        x[k] = s
        J = system.dynamics_jacobian(x)
        C = system.output_jacobian(x)
        found = _undetectable_mode(J, C)
        if found is None:
            continue
        lam, v, res = found
        if any(abs(p.s - s) <= 1e-9 * max(1.0, abs(s)) for p in out):
            continue
        xdot = system.rhs(x, np.zeros(system.m))
        eq = bool(np.linalg.norm(xdot) <= EQUILIBRIUM_RTOL * (1.0 + np.linalg.norm(x)))
        k_big = int(np.argmax(np.abs(v)))
        v = v * np.exp(-1j * np.angle(v[k_big]))
        v = v / np.linalg.norm(v)
        if np.allclose(v.imag, 0.0, atol=1e-12):
            v = np.real(v)
        out.append(UndetectablePoint(system, x, k, float(s), lam, v, eq, res))
    return _thin(out, 1.5 * (hi - lo) / max(int(samples) - 1, 1))


def _thin(points: list[UndetectablePoint], spacing: float) -> list[UndetectablePoint]:
    """One point per run of neighbouring candidates (closer than ``spacing``): the smallest residual."""
    groups: list[list[UndetectablePoint]] = []
    for p in sorted(points, key=lambda q: q.s):
        if groups and p.s - groups[-1][-1].s <= spacing:
            groups[-1].append(p)
        else:
            groups.append([p])
    return [min(g, key=lambda q: q.pbh_residual) for g in groups]


# ---------------------------------------------------------------------------- mirror symmetry
@dataclass(frozen=True)
class OutputSymmetry(Certificate):
    """An involution ``T x = c + S (x - c)`` under which the system's outputs cannot tell ``x`` from ``T x``.

    Parameters
    ----------
    S : (n, n) array
        Diagonal sign matrix (not the identity).
    c : (n,) array
        Centre of the mirror (only the flipped coordinates matter).
    points : int
        Random points of ``box ∩ T(box)`` at which equivariance and invariance were checked.
    residual : float
        Largest relative residual found there.
    example_pair : (array, array)
        A state and its mirror image, both in the box.
    system : ScalarNonlinearSystem
        The system.
    lower, upper : (n,) arrays
        Box ``box ∩ T(box)`` in which :meth:`verify` draws its points.

    See Also
    --------
    output_symmetries : Finds them.
    UndetectablePoint : The local counterpart (a non-detectable linearisation).

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A rotation measured through ``cos(x1)``: the output cannot tell ``x`` from ``-x``.

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("x1", "x2"))
    >>> import casadi as ca
    >>> cosine = ScalarFunction("cos", ca.cos, lambda z: -ca.sin(z))   # CasADi expressions
    >>> system = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [-1.0, 0.0]], C=[[1.0, 0.0]], h=(cosine,),
    ...                                name="mirror")
    >>> from hybobs_opt.lmi import output_symmetries
    >>> sym = output_symmetries(system)[0]
    >>> np.diag(sym.S), sym.flipped
    (array([-1., -1.]), ['x1', 'x2'])
    >>> x = np.array([0.5, 0.2])
    >>> sym.map(x), bool(np.isclose(np.cos(x[0]), np.cos(sym.map(x)[0])))
    (array([-0.5, -0.2]), True)
    >>> sym.verify()
    True
    """

    system: ScalarNonlinearSystem = field(repr=False)
    S: np.ndarray
    c: np.ndarray
    points: int
    residual: float
    example_pair: tuple[np.ndarray, np.ndarray]
    lower: np.ndarray = field(repr=False, default=None)
    upper: np.ndarray = field(repr=False, default=None)

    def map(self, x) -> np.ndarray:
        """The mirror map ``x -> c + S (x - c)``.

        Parameters
        ----------
        x : (n,) or (N, n) array_like
            State(s).

        Returns
        -------
        ndarray
            The mirror map ``x -> c + S (x - c)``.
        """
        x = np.asarray(x, dtype=float)
        return self.c + (x - self.c) * np.diag(self.S)

    def verify(self, points: int = SYMMETRY_POINTS, seed: int = 1) -> bool:
        """Re-check equivariance and invariance at fresh random points.

        Parameters
        ----------
        points : int, default SYMMETRY_POINTS
            Number of random points drawn in ``[lower, upper]`` (:data:`~hybobs_opt.defaults.SYMMETRY_POINTS`).
        seed : int, default 1
            Seed of the random points (the search itself uses 0, so these are fresh).

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        res = _symmetry_residual(self.system, np.diag(self.S), self.c, self.lower, self.upper, points, seed)
        return res is not None and res <= SYMMETRY_RTOL

    @property
    def flipped(self) -> list[str]:
        return [self.system.state_names[i] for i in np.nonzero(np.diag(self.S) < 0)[0]]

    @property
    def reason(self) -> str:
        """The certificate's statement (:attr:`claim`)."""
        return self.claim

    @property
    def claim(self) -> str:
        names = self.system.state_names
        flips = ", ".join(f"{names[i]} -> {2 * self.c[i]:.6g} - {names[i]}" if self.c[i] != 0 else f"{names[i]} -> -{names[i]}"
                          for i in np.nonzero(np.diag(self.S) < 0)[0])
        x, xp = self.example_pair
        return (f"Globally unobservable: the mirror map ({flips}) leaves the outputs unchanged and maps trajectories onto "
                f"trajectories (checked at {self.points} points to {SYMMETRY_RTOL:g}), so x and its mirror give the same "
                f"outputs for every input and all time, e.g. x = {np.round(x, 6).tolist()} and x' = {np.round(xp, 6).tolist()}; "
                f"no observer can tell them apart, and an estimate can converge to the mirror branch.")

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"flipped": self.flipped, "S": np.diag(self.S).tolist(), "c": self.c.tolist(), "points": self.points,
                "residual": self.residual, "example_pair": [self.example_pair[0].tolist(), self.example_pair[1].tolist()],
                "verified": self.verify(), "claim": self.claim}


def _symmetry_residual(system, signs, c, lo, hi, points, seed) -> float | None:
    rng = np.random.default_rng(seed)
    X = lo + (hi - lo) * rng.random((points, system.n))
    X = X[[system.box.contains(x) for x in X]] if not _is_box(system) else X
    if X.shape[0] == 0:
        return None
    TX = c + (X - c) * signs
    U = rng.standard_normal((X.shape[0], system.m)) if system.m else np.zeros((X.shape[0], 0))
    f1 = system.rhs(X, U) * signs
    f2 = system.rhs(TX, U)
    y1, y2 = system.output(X), system.output(TX)
    sf = 1.0 + float(np.abs(f1).max())
    sy = 1.0 + float(np.abs(y1).max())
    return max(float(np.abs(f1 - f2).max()) / sf, float(np.abs(y1 - y2).max()) / sy)


def _is_box(system) -> bool:
    lo, hi = system.box_lower, system.box_upper
    corners = [np.where(np.array(b, dtype=bool), hi, lo) for b in itertools.product((0, 1), repeat=min(system.n, 10))]
    return system.n <= 10 and all(system.box.contains(x) for x in corners)


def _centre_candidates(system: ScalarNonlinearSystem, k: int) -> list[float]:
    """Mirror centres to try for coordinate ``k``: 0, the box centre, and the extrema of every
    scalar function acting on ``x_k`` alone (an even function is even about its extrema)."""
    lo, hi = float(system.box_lower[k]), float(system.box_upper[k])
    out = [0.0, 0.5 * (lo + hi)]
    for rows, fns in ((system.E, system.f), (system.C, system.h)):
        for row, fn in zip(rows, fns):
            if row[k] == 0 or np.count_nonzero(row) != 1 or fn.is_identity:
                continue
            a, b = sorted((row[k] * lo, row[k] * hi))
            out += [z / row[k] for z in slope_change_points(fn, a, b)]
    uniq: list[float] = []
    for v in out:
        if lo - 1e-12 <= v <= hi + 1e-12 or v == 0.0:
            if all(abs(v - u) > 1e-9 * max(1.0, abs(v)) for u in uniq):
                uniq.append(float(v))
    return uniq


def output_symmetries(system: ScalarNonlinearSystem, *, points: int = SYMMETRY_POINTS, seed: int = 0) -> list[OutputSymmetry]:
    """Mirror maps ``x -> c + S (x - c)`` that the outputs cannot detect (see the module docstring).

    Every diagonal sign pattern ``S != I`` with ``S B = B`` is tried with the centres of
    :func:`_centre_candidates` for the flipped coordinates; a candidate is accepted when the
    vector field is equivariant and the output invariant at ``points`` random points of
    ``box ∩ T(box)`` to :data:`~hybobs_opt.tolerances.SYMMETRY_RTOL`, and ``T`` moves some of them.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    points : int, default SYMMETRY_POINTS
        Random points at which each candidate is checked.
    seed : int, default 0
        Seed of the random points.

    Returns
    -------
    list of OutputSymmetry
        The mirror maps found (empty when there is none); each proves that no observer can recover
        the flipped coordinates' sign from the outputs.

    See Also
    --------
    OutputSymmetry : One mirror map and its re-check.
    undetectable_points : States where the linearisation is not detectable.
    diagnose : Reports both with the LMI's verdict.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A rotation measured through ``cos(x1)``: the output cannot tell ``x`` from ``-x``.

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("x1", "x2"))
    >>> import casadi as ca
    >>> cosine = ScalarFunction("cos", ca.cos, lambda z: -ca.sin(z))   # CasADi expressions
    >>> system = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [-1.0, 0.0]], C=[[1.0, 0.0]], h=(cosine,),
    ...                                name="mirror")
    >>> from hybobs_opt.lmi import output_symmetries
    >>> found = output_symmetries(system)
    >>> len(found), found[0].verify()
    (1, True)
    >>> print(found[0].claim)  # doctest: +ELLIPSIS
    Globally unobservable: the mirror map (x1 -> -x1, x2 -> -x2) leaves the outputs ...
    """
    n = system.n
    lo_box, hi_box = system.box_lower, system.box_upper
    found: list[OutputSymmetry] = []
    budget = MAX_SYMMETRY_CANDIDATES
    for pattern in itertools.product((1.0, -1.0), repeat=n):
        signs = np.array(pattern)
        if np.all(signs > 0):
            continue
        if system.m and not np.allclose(signs[:, None] * system.B, system.B):
            continue
        flipped = np.nonzero(signs < 0)[0]
        options = [_centre_candidates(system, k) for k in flipped]
        for combo in itertools.product(*options):
            budget -= 1
            if budget < 0:
                return found
            c = 0.5 * (lo_box + hi_box)
            c[flipped] = combo
            # box ∩ T(box): T maps [lo, hi] of a flipped coordinate to [2c - hi, 2c - lo]
            lo = lo_box.copy()
            hi = hi_box.copy()
            lo[flipped] = np.maximum(lo_box[flipped], 2 * c[flipped] - hi_box[flipped])
            hi[flipped] = np.minimum(hi_box[flipped], 2 * c[flipped] - lo_box[flipped])
            width = hi_box - lo_box
            if np.any(hi - lo <= 1e-6 * np.where(width > 0, width, 1.0)):
                continue
            res = _symmetry_residual(system, signs, c, lo, hi, points, seed)
            if res is None or res > SYMMETRY_RTOL:
                continue
            # an example pair far apart: the corner of the common box farthest from its mirror
            x = np.where(signs < 0, hi, 0.5 * (lo + hi))
            xp = c + (x - c) * signs
            found.append(OutputSymmetry(system, np.diag(signs), c, points, float(res), (x, xp), lo, hi))
    return found
