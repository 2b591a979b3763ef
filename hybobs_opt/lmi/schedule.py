"""Regions of a scheduling variable: the operating sub-boxes of a switched-gain observer (paper 004).

A switched-gain observer (paper 004, Section 5, Fig. 1) uses one constant gain per region of one
scalar *scheduling coordinate* of the state -- the yaw angle ``psi`` of the vehicle (Section 6:
``0 <= psi <= 80 deg`` and ``60 <= psi <= 140 deg``), the piston position ``z`` (Section 7,
regions ``R_1 .. R_11`` of Fig. 7).  A region is the operating box of the system with that one
coordinate restricted to an interval; neighbouring regions overlap by twice the hysteresis
``epsilon`` of Fig. 1 (Theorem 6 needs the overlap to enforce a dwell time).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..geometry.lp import row_range
from ..systems.scalar_nonlinear import ScalarNonlinearSystem


@dataclass(frozen=True)
class SchedulingRegion:
    """The operating box with state ``coordinate`` restricted to ``[lo, hi]`` (model units).

    Parameters
    ----------
    coordinate : int
        Index of the scheduling state.
    name : str
        Its name (``"psi"``, ``"z"``).
    lo, hi : float
        The interval, ``lo < hi``, in the model's units (radians for ``psi``).
    index : int
        Position of the region in its partition (0-based).

    See Also
    --------
    make_region : Build a region checked against a system's operating box.
    regions_from_switch_points : Overlapping regions around switching points (Fig. 1).
    grow_regions : Regions grown where a gain of a given decay rate exists.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> region = make_region(vehicle, "psi", 0.0, math.radians(80))
    >>> region.name, region.coordinate
    ('psi', 2)
    >>> round(region.width, 4)
    1.3963
    >>> region.contains(math.radians(45)), region.contains(math.radians(100))
    (True, False)
    """

    coordinate: int
    name: str
    lo: float
    hi: float
    index: int = 0

    def __post_init__(self) -> None:
        for label, value in (("lo", self.lo), ("hi", self.hi)):
            if not np.isfinite(value):
                raise ModelError(f"region {self.name}.{label}", "a finite number", repr(value))
        if not self.lo < self.hi:
            raise ModelError(f"region of {self.name}", "a non-empty interval lo < hi",
                             f"[{self.lo:.6g}, {self.hi:.6g}]")

    @property
    def width(self) -> float:
        return self.hi - self.lo

    def contains(self, value: float) -> bool:
        """Whether ``lo <= value <= hi``.

        Parameters
        ----------
        value : float
            Value of the scheduling state, in model units.

        Returns
        -------
        bool
            Whether ``lo <= value <= hi``.
        """
        return self.lo <= value <= self.hi

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"index": self.index, "coordinate": self.name, "lo": self.lo, "hi": self.hi}


def coordinate_index(system: ScalarNonlinearSystem, coordinate: int | str) -> int:
    """Index of a state given by index or name (``ModelError`` names the valid states)."""
    if isinstance(coordinate, str):
        try:
            return system.state_names.index(coordinate)
        except ValueError:
            raise ModelError("scheduling coordinate", f"one of the states {system.state_names}", repr(coordinate)) from None
    k = int(coordinate)
    if not 0 <= k < system.n:
        raise ModelError("scheduling coordinate", f"a state index in [0, {system.n})", repr(coordinate))
    return k


def make_region(system: ScalarNonlinearSystem, coordinate: int | str, lo: float, hi: float, index: int = 0) -> SchedulingRegion:
    """A region of ``system``, checked against the operating box.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system whose operating box the region restricts.
    coordinate : int or str
        The scheduling state (index or name).
    lo, hi : float
        The interval in model units.
    index : int, default 0
        Position of the region in its partition.

    Returns
    -------
    SchedulingRegion
        The region, with the coordinate's index and name resolved.

    Raises
    ------
    ModelError
        ``lo >= hi`` (an empty region), non-finite ends, or an interval that does not meet the
        box's range of the coordinate.

    See Also
    --------
    SchedulingRegion : The region it returns.
    regions_from_switch_points : Several overlapping regions at once.
    jacobian_bounds : The Jacobian bounds (4)-(5) over a region.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> region = make_region(vehicle, "psi", 0.0, math.radians(80))
    >>> region.coordinate, region.name, region.lo, round(region.hi, 4)
    (2, 'psi', 0.0, 1.3963)

    A reversed range is refused:

    >>> make_region(vehicle, "psi", 1.0, 0.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    hybobs_opt.errors.ModelError: region of psi: expected a non-empty interval lo < hi, got [1, 0]
    """
    k = coordinate_index(system, coordinate)
    region = SchedulingRegion(k, system.state_names[k], float(lo), float(hi), index)
    blo, bhi = float(system.box_lower[k]), float(system.box_upper[k])
    if region.hi <= blo or region.lo >= bhi:
        raise ModelError(f"region of {region.name}", f"an interval meeting the operating range [{blo:.6g}, {bhi:.6g}]",
                         f"[{region.lo:.6g}, {region.hi:.6g}] (an empty region)")
    return region


def _is_axis_box(system: ScalarNonlinearSystem) -> bool:
    A = system.box.A
    return bool(np.all(np.count_nonzero(np.abs(A) > 0, axis=1) == 1))


def argument_intervals(system: ScalarNonlinearSystem, rows: np.ndarray, region: SchedulingRegion | None) -> np.ndarray:
    """``[min, max]`` of each ``row . x`` over the box restricted to ``region``, ``(k, 2)``.

    Interval arithmetic when the operating set is an axis-aligned box (the examples), two LPs
    per row otherwise.
    """
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    lo = system.box_lower.astype(float).copy()
    hi = system.box_upper.astype(float).copy()
    if region is not None:
        k = region.coordinate
        lo[k] = max(lo[k], region.lo)
        hi[k] = min(hi[k], region.hi)
        if lo[k] > hi[k]:
            raise ModelError(f"region of {region.name}", f"an interval meeting the operating range [{system.box_lower[k]:.6g}, {system.box_upper[k]:.6g}]",
                             f"[{region.lo:.6g}, {region.hi:.6g}] (an empty region)")
    out = np.empty((rows.shape[0], 2))
    if _is_axis_box(system):
        pos, neg = np.clip(rows, 0, None), np.clip(rows, None, 0)
        out[:, 0] = pos @ lo + neg @ hi
        out[:, 1] = pos @ hi + neg @ lo
        return out
    A, b = system.box.A, system.box.b
    if region is not None:
        e = np.zeros(system.n)
        e[region.coordinate] = 1.0
        A = np.vstack([A, e, -e])
        b = np.concatenate([b, [region.hi, -region.lo]])
    return row_range(A, b, rows, problem="range over the region", field="region")


def regions_from_switch_points(
    system: ScalarNonlinearSystem,
    coordinate: int | str,
    lo: float,
    hi: float,
    switch_points: Sequence[float],
    overlap: float,
) -> list[SchedulingRegion]:
    """Regions ``[s_{k-1} - eps, s_k + eps]`` around nominal switching points (paper 004, Fig. 1).

    With ``s_0 = lo``, ``s_K = hi`` and ``eps = overlap``: the paper's vehicle split,
    ``0-80 deg`` and ``60-140 deg`` (eqs. 61-62), is ``switch_points = [70 deg]``, ``overlap =
    10 deg``.  Neighbouring regions share ``2 eps``; the hysteresis state machine switches when the
    estimate leaves its region, i.e. at ``s_k + eps`` going up and ``s_k - eps`` going down.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system whose operating box the regions restrict.
    coordinate : int or str
        The scheduling state (index or name).
    lo, hi : float
        The range covered, in model units.
    switch_points : sequence of float
        Nominal switching points ``s_1 < ... < s_{K-1}`` inside ``(lo, hi)``.
    overlap : float
        The hysteresis ``eps >= 0`` (model units).

    Returns
    -------
    list of SchedulingRegion
        ``K = len(switch_points) + 1`` regions, indexed in order.

    Raises
    ------
    ModelError
        Unsorted switching points, points outside ``(lo, hi)``, a negative overlap, or an
        overlap so wide that a region would reach past its neighbour's switching point.

    See Also
    --------
    make_region : One region.
    adjacent_pairs : The switches between the regions.
    grow_regions : Regions grown from the LMI instead of given switching points.

    Examples
    --------
    The vehicle split of paper 004, eqs. (61)-(62): 0-80 deg and 60-140 deg.

    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> [(r.index, round(math.degrees(r.lo)), round(math.degrees(r.hi))) for r in regions]
    [(0, 0, 80), (1, 60, 140)]
    """
    k = coordinate_index(system, coordinate)
    pts = [float(s) for s in switch_points]
    if not (np.isfinite(overlap) and overlap >= 0):
        raise ModelError("overlap", "a non-negative hysteresis width", repr(overlap))
    if not lo < hi:
        raise ModelError("range", "lo < hi (a non-empty range)", f"[{lo:.6g}, {hi:.6g}]")
    edges = [float(lo), *pts, float(hi)]
    if any(not (b > a) for a, b in zip(edges[:-1], edges[1:])):
        raise ModelError("switch_points", f"increasing points strictly inside ({lo:.6g}, {hi:.6g})", f"{pts}")
    gaps = np.diff(edges)
    if len(pts) and overlap > 0.5 * float(gaps.min()):
        raise ModelError("overlap", f"at most half the narrowest region ({0.5 * float(gaps.min()):.6g})", f"{overlap:.6g}")
    out = []
    for i in range(len(edges) - 1):
        a = edges[i] - (overlap if i > 0 else 0.0)
        b = edges[i + 1] + (overlap if i < len(edges) - 2 else 0.0)
        out.append(make_region(system, k, a, b, i))
    return out


def adjacent_pairs(regions: Sequence[SchedulingRegion]) -> list[tuple[int, int]]:
    """Ordered pairs ``(i, j)`` of overlapping regions: the switches the observer can make.

    Parameters
    ----------
    regions : sequence of SchedulingRegion
        The regions, in their partition's order.

    Returns
    -------
    list of (int, int)
        Indices into ``regions``; both orders of each overlapping pair are listed.

    See Also
    --------
    regions_from_switch_points : Overlapping regions whose pairs this lists.
    synthesize_switched : Uses the pairs for the dwell-time LMIs (47)-(48).

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import adjacent_pairs, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> adjacent_pairs(regions)
    [(0, 1), (1, 0)]
    """
    pairs = []
    for i, a in enumerate(regions):
        for j, b in enumerate(regions):
            if i != j and a.lo <= b.hi and b.lo <= a.hi:
                pairs.append((i, j))
    return pairs
