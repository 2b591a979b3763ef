"""Paper 004's magnetic piston (Section 7, eq. 63) made piecewise affine.

The piston's integrator chain is linear; only its two sensor curves ``h_1(z)``, ``h_2(z)`` are
nonlinear.  Replacing each curve by a continuous piecewise-linear interpolant in the position
``z`` makes the plant a PWA system (paper 002, eq. 1) with one mode per ``z``-interval, so the
lookup-table deadbeat observer of paper 002 applies to it and can be compared with the
switched-gain observer of paper 004 (:mod:`.piston_comparison`).

This module is not registered in the example registry: it is a derived model used by that
comparison, not a system of the seed papers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from hybobs_opt.errors import ModelError
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.systems.pwa import PWASystem
from hybobs_opt.studies.paper004_nonmonotonic.systems import PISTON_A_MAX, PISTON_DT, PISTON_STROKE_MM, PISTON_V_MAX, magnetic_piston


#: The fit error of the piecewise-linear sensor fit is measured on a grid of step 0.0102 mm.  Between
#: grid points the error can exceed the sampled maximum by at most ``0.5 max|h''| (0.0051 mm)^2``,
#: about 6.5e-7 mT for the synthetic curves (``|h''| <= 0.05 mT/mm^2``); a check on another grid
#: accepts this much more (mT): 15 times that, and far below any real misfit (the fits are off by
#: 0.07 mT or more).
PWL_FIT_GRID_ATOL: float = 1e-5

#: The two pieces meeting at a breakpoint of the PWL fit agree there to this, relative to the size
#: of the readings: ``slope * z + offset`` rounds to ~1e-15 relative; a discontinuity would be
#: of the size of the readings' change over a piece.
PWL_CONTINUITY_RTOL: float = 1e-12

#: "Exact" reconstruction by the lookup observer on the PWA piston: ``|x_hat - x|`` divided by the
#: state box's half-widths (DESIGN.md's scaled coordinates) at every step flagged observable.
#: Measured about 4e-11: the acceleration is a second difference of positions 1 ms apart, so the
#: rounding of ``z`` (~1e-14 mm) becomes ~2e-7 mm/s^2, i.e. 4e-11 of the 5000 mm/s^2 bound.
PISTON_LOOKUP_EXACT_RTOL: float = 1e-8

#: Bound of the jerk input (mm/s^3) of the PWA model's input set ``U``.  NOT in paper 004 (its
#: model has no input bound); it reaches the acceleration bound from rest in 0.5 s and is 27 times
#: the scenario's peak jerk (about 374 mm/s^3), so the scenario is far inside ``U``.
PISTON_JERK_MAX = 1.0e4

#: Uniform grid (points over the stroke, plus the breakpoints) on which the fit error is measured.
#: The grid step is 0.0102 mm; the error's peak on a piece is a smooth maximum of curvature
#: ``|h''| <= 0.05 mT/mm^2``, so the sampled maximum is below the true one by at most 6.5e-7 mT
#: (see :data:`PWL_FIT_GRID_ATOL`).
FIT_CHECK_SAMPLES = 20_001

#: Samples of each sensor's derivative used to locate the slope changes before brentq refines them.
_EXTREMA_SAMPLES = 20_001


@dataclass(frozen=True, eq=False)
class SensorFit:
    """A continuous piecewise-linear interpolant of the piston's two sensor curves.

    Attributes
    ----------
    breakpoints : (K + 1,) array
        Ends of the ``K`` pieces (mm), from ``0`` to the stroke, increasing.
    values : (K + 1, 2) array
        ``h_1``, ``h_2`` of the smooth model at the breakpoints (mT): the fit interpolates there.
    slopes, offsets : (K, 2) arrays
        On piece ``k`` the fit is ``slopes[k] * z + offsets[k]`` (mT/mm, mT).
    extrema : (E,) array
        The slope changes of the smooth curves inside the stroke (mm); all are breakpoints.
    pieces_per_monotonic_piece : (E + 1,) int array
        How many equal sub-pieces each monotonic piece was split into.
    max_error, rms_error : (2,) arrays
        ``max |fit - h_j|`` and its RMS over :data:`FIT_CHECK_SAMPLES` uniform points plus the
        breakpoints (mT), per sensor.
    max_error_position : (2,) array
        Where each maximum occurs (mm).
    method : str
        How the breakpoints were placed (human-readable).
    """

    breakpoints: np.ndarray
    values: np.ndarray
    slopes: np.ndarray
    offsets: np.ndarray
    extrema: np.ndarray
    pieces_per_monotonic_piece: np.ndarray
    max_error: np.ndarray
    rms_error: np.ndarray
    max_error_position: np.ndarray
    method: str

    @property
    def n_pieces(self) -> int:
        """Number of linear pieces (modes of the PWA model)."""
        return int(self.breakpoints.size - 1)

    def __call__(self, z) -> np.ndarray:
        """The fitted readings ``(N, 2)`` (mT) at positions ``z`` (mm) inside the stroke."""
        z = np.atleast_1d(np.asarray(z, dtype=float))
        return np.stack([np.interp(z, self.breakpoints, self.values[:, j]) for j in range(2)], axis=-1)

    def to_dict(self) -> dict:
        """JSON-ready description: method, pieces, breakpoints and the fit errors (mT)."""
        return {
            "method": self.method, "n_pieces": self.n_pieces, "breakpoints_mm": self.breakpoints.tolist(),
            "extrema_mm": self.extrema.tolist(), "pieces_per_monotonic_piece": self.pieces_per_monotonic_piece.tolist(),
            "max_error_mT": self.max_error.tolist(), "rms_error_mT": self.rms_error.tolist(),
            "max_error_position_mm": self.max_error_position.tolist(),
        }


def _slope_changes(fn, lo: float, hi: float) -> list[float]:
    """Positions in ``(lo, hi)`` where ``fn'`` changes sign, refined by brentq to 1e-12 mm."""
    z = np.linspace(lo, hi, _EXTREMA_SAMPLES)
    d = fn.deriv(z)
    out = []
    for k in np.nonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)[0]:
        out.append(brentq(lambda t: float(fn.deriv(np.array([t]))[0]), z[k], z[k + 1], xtol=1e-12))
    return out


def _chord_error(h, a: float, b: float, count: int, samples: int = 201) -> float:
    """Largest deviation of the interpolant with ``count`` equal pieces on ``[a, b]`` from ``h``."""
    edges = np.linspace(a, b, count + 1)
    z = np.linspace(a, b, samples * count)
    exact = h(z)
    fit = np.stack([np.interp(z, edges, h(edges)[:, j]) for j in range(exact.shape[1])], axis=-1)
    return float(np.max(np.abs(fit - exact)))


def piston_sensor_fit(n_pieces: int | None = None, stroke: float = PISTON_STROKE_MM) -> SensorFit:
    """Continuous piecewise-linear interpolant in ``z`` of the sensor curves of eq. (63), paper 004.

    The breakpoints are **the monotonic-piece boundaries of the curves** (the 10 slope changes of
    ``h_1`` and ``h_2`` inside the stroke, so every piece lies in one of the 11 intervals where
    both readings are monotonic, the counterpart of the paper's regions R_1..R_11 of Fig. 7),
    each monotonic piece optionally split into equal sub-pieces.  The fit passes through the smooth
    curves at every breakpoint, so it is continuous there by construction.

    Parameters
    ----------
    n_pieces : int, optional
        Total number of pieces.  ``None``: the monotonic pieces alone (11).  More pieces are
        handed out one at a time to the monotonic piece whose current maximum fit error is the
        largest (greedy; the result is deterministic).
    stroke : float
        Position range (mm), as in :func:`~hybobs_opt.studies.paper004_nonmonotonic.systems.magnetic_piston`.

    Returns
    -------
    SensorFit
        With the fit error against the smooth curves measured on a grid (see :class:`SensorFit`).

    Raises
    ------
    ModelError
        If ``n_pieces`` is smaller than the number of monotonic pieces.
    """
    smooth = magnetic_piston(stroke=stroke)
    lo, hi = float(smooth.box_lower[0]), float(smooth.box_upper[0])

    def h(z: np.ndarray) -> np.ndarray:
        return np.stack([np.asarray(fn.value(z), dtype=float).reshape(-1) for fn in smooth.h], axis=-1)

    extrema = np.unique(np.round(sorted(p for fn in smooth.h for p in _slope_changes(fn, lo, hi)), 12))
    edges = np.concatenate([[lo], extrema, [hi]])
    n_mono = edges.size - 1
    if n_pieces is None:
        n_pieces = n_mono
    if not isinstance(n_pieces, (int, np.integer)) or n_pieces < n_mono:
        raise ModelError("n_pieces", f"an integer of at least {n_mono} (the monotonic pieces of the sensor curves)",
                         repr(n_pieces))
    counts = np.ones(n_mono, dtype=int)
    errors = np.array([_chord_error(h, edges[k], edges[k + 1], 1) for k in range(n_mono)])
    for _ in range(int(n_pieces) - n_mono):
        k = int(np.argmax(errors))
        counts[k] += 1
        errors[k] = _chord_error(h, edges[k], edges[k + 1], int(counts[k]))
    bps = np.concatenate([np.linspace(edges[k], edges[k + 1], counts[k] + 1)[:-1] for k in range(n_mono)] + [[hi]])
    values = h(bps)
    slopes = np.diff(values, axis=0) / np.diff(bps)[:, None]
    offsets = values[:-1] - slopes * bps[:-1, None]
    z = np.union1d(np.linspace(lo, hi, FIT_CHECK_SAMPLES), bps)
    dev = np.abs(np.stack([np.interp(z, bps, values[:, j]) for j in range(2)], axis=-1) - h(z))
    method = ("breakpoints at the slope changes of h_1, h_2 (monotonic-piece boundaries)"
              + ("" if n_pieces == n_mono else "; each monotonic piece split into equal sub-pieces, "
                 "added greedily where the maximum fit error is largest"))
    return SensorFit(bps, values, slopes, offsets, extrema, counts, dev.max(axis=0),
                     np.sqrt(np.mean(dev**2, axis=0)), z[np.argmax(dev, axis=0)], method)


def magnetic_piston_pwa(
    n_pieces: int | None = None,
    Ts: float = PISTON_DT,
    *,
    stroke: float = PISTON_STROKE_MM,
    v_max: float = PISTON_V_MAX,
    a_max: float = PISTON_A_MAX,
    jerk_max: float = PISTON_JERK_MAX,
    fit: SensorFit | None = None,
) -> PWASystem:
    """The magnetic piston of paper 004, eq. (63), with piecewise-linear sensor curves: a PWA system.

    States ``x = [z, v, a]`` (mm, mm/s, mm/s^2), input the jerk ``u`` (mm/s^3), outputs the two
    magnetic readings (mT), as in :func:`~hybobs_opt.studies.paper004_nonmonotonic.systems.magnetic_piston`.

    * **Dynamics**: the chain of integrators of eq. (63) (``A`` with ones above the diagonal,
      ``B = e_3``), discretised exactly by zero-order hold with period ``Ts``
      (:meth:`HybridAutomaton.discretize`); it is the same in every mode.
    * **Outputs (what is fitted)**: the synthetic sensor curves ``h_1(z)``, ``h_2(z)`` of the smooth
      model are replaced by the continuous piecewise-linear interpolant of
      :func:`piston_sensor_fit` (breakpoints at the monotonic-piece boundaries of the curves,
      optionally subdivided).  On piece ``k``, ``y = C_k x + c_k`` with ``C_k = [s_k 0 0]``
      (``s_k`` the two slopes) and ``c_k`` the two offsets.  The fit error is
      ``piston_sensor_fit(n_pieces).max_error`` (1.06 mT for the 11 monotonic pieces, 0.32 mT
      for 22, 0.075 mT for 44 pieces, on curves reaching about +-4.7 mT).
    * **Modes**: one per ``z``-interval, guard ``z_k <= z <= z_{k+1}`` (lifted to ``(x, u)``);
      neighbouring intervals share their boundary, which the first mode wins (PWASystem's rule).
    * **Bounds**: ``X`` is the smooth model's operating box (``0 <= z <= stroke``, ``|v| <= v_max``,
      ``|a| <= a_max``); ``U`` is ``|u| <= jerk_max`` (:data:`PISTON_JERK_MAX`, an assumption).

    Parameters
    ----------
    n_pieces : int, optional
        Pieces of the fit (default: the 11 monotonic pieces), see :func:`piston_sensor_fit`.
    Ts : float
        Sampling period (s); default 1 ms, the period of the smooth piston scenario.
    stroke, v_max, a_max : float
        The smooth model's box (mm, mm/s, mm/s^2).
    jerk_max : float
        Input bound (mm/s^3).
    fit : SensorFit, optional
        A fit already computed by :func:`piston_sensor_fit` for this stroke (``n_pieces`` is then
        ignored).

    Returns
    -------
    PWASystem
        ``n = 3``, ``m = 1``, ``p = 2``, one mode per piece, named ``"z[lo, hi]"``.
    """
    if not (np.isfinite(jerk_max) and jerk_max > 0):
        raise ModelError("jerk_max", "a positive finite jerk bound (mm/s^3)", repr(jerk_max))
    smooth = magnetic_piston(stroke=stroke, v_max=v_max, a_max=a_max)
    if fit is None:
        fit = piston_sensor_fit(n_pieces, stroke=stroke)
    elif not isinstance(fit, SensorFit) or not np.isclose(fit.breakpoints[-1], stroke):
        raise ModelError("fit", f"a SensorFit over the stroke 0-{stroke:g} mm", repr(fit))
    n = smooth.n
    locations = []
    for k, (a, b) in enumerate(zip(fit.breakpoints[:-1], fit.breakpoints[1:])):
        C = np.zeros((smooth.p, n))
        C[:, 0] = fit.slopes[k]
        inv = Polytope(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]), np.array([b, -a]), smooth.state_names)
        locations.append(Location(f"z[{a:.2f}, {b:.2f}]", inv, A=smooth.A, B=smooth.B, C=C, c=fit.offsets[k]))
    K = len(locations)
    edges = tuple(Edge(i, j) for i in range(K) for j in (i - 1, i + 1) if 0 <= j < K)
    automaton = HybridAutomaton(
        tuple(locations), smooth.box, edges, Polytope.from_box([-jerk_max], [jerk_max], smooth.input_names),
        smooth.state_names, smooth.input_names, smooth.output_names, name=f"magnetic_piston_pwa ({K} pieces)",
    )
    return automaton.discretize(Ts)
