"""Volumes of polytopes and unions: the estimate type, qhull's hull volume (checked) and Monte Carlo."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError, SolverError


@dataclass(frozen=True)
class VolumeEstimate:
    """Volume of a polytope or union of polytopes.

    Parameters
    ----------
    value : float
        The volume (exact, or the Monte Carlo estimate).
    stderr : float
        Standard error of ``value``: ``0.0`` for the exact method.
    method : str
        ``"exact"`` (convex hull of the vertices) or ``"monte-carlo"`` (hit-and-miss in the
        bounding box).
    n_samples : int
        Number of Monte Carlo samples (``0`` for the exact method).

    See Also
    --------
    monte_carlo_volume : the sampled estimate.

    Examples
    --------
    :meth:`Polytope.volume` returns one: exact (qhull or cddlib) in low dimension.

    >>> from hybobs_opt.geometry import Polytope
    >>> estimate = Polytope.from_box([0.0, 0.0, 0.0], [1.0, 2.0, 3.0]).volume()
    >>> round(estimate.value, 6), estimate.stderr, estimate.method, estimate.n_samples
    (6.0, 0.0, 'exact', 0)
    """

    value: float
    stderr: float
    method: str
    n_samples: int = 0


def monte_carlo_volume(
    contains: Callable[[np.ndarray], np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    n_samples: int,
    rng: np.random.Generator | int | None = None,
) -> tuple[float, float]:
    """Hit-and-miss volume of a set inside the box ``[lo, hi]``.

    Parameters
    ----------
    contains : callable
        Vectorised membership ``(N, d) -> (N,) bool``.
    lo, hi : (d,) arrays
        A box containing the set.
    n_samples : int
        Number of uniform samples.
    rng : numpy Generator or seed, optional

    Returns
    -------
    value, stderr : float
        ``p V_box`` and ``V_box sqrt(p (1 - p) / n)`` with ``p`` the hit fraction.

    See Also
    --------
    VolumeEstimate : the volume with its method and error.
    Polytope.volume : the exact volume of one polytope.

    Examples
    --------
    The unit disc (area pi) from 20000 samples of the box ``[-1, 1]^2``; a seed makes it
    reproducible:

    >>> import numpy as np
    >>> from hybobs_opt.geometry import monte_carlo_volume
    >>> value, stderr = monte_carlo_volume(lambda z: (z ** 2).sum(axis=1) <= 1.0, -np.ones(2), np.ones(2),
    ...                                    20000, rng=0)
    >>> round(value, 2), round(stderr, 3)
    (3.16, 0.012)
    """
    if n_samples < 1:
        raise ModelError("n_samples", "a positive integer", str(n_samples))
    gen = np.random.default_rng(rng)
    lo = np.asarray(lo, dtype=float)
    width = np.asarray(hi, dtype=float) - lo
    hits, done = 0, 0
    while done < n_samples:
        m = min(_MC_BATCH, n_samples - done)
        hits += int(np.count_nonzero(contains(lo + width * gen.random((m, lo.size)))))
        done += m
    p = hits / n_samples
    vbox = float(np.prod(width))
    return p * vbox, vbox * float(np.sqrt(p * (1.0 - p) / n_samples))


def checked_hull_volume(Y: np.ndarray) -> float:
    """Volume of the convex hull of full-dimensional points (scaled to about the unit box), by qhull.

    qhull's hull, checked by :func:`~hybobs_opt.geometry._hull_cycle.checked_hull`: its
    triangulation closes up into the boundary and covers it once (the volume is then the sum of the
    simplices' pyramids ``|det(p_1 - c, ..., p_d - c)| / d!`` about the points' centroid ``c``),
    or else its facets are closed under adjacency, each with its own checked hull one dimension
    down (the volume is then the sum of the pyramids over the facets).

    Parameters
    ----------
    Y : (n, d) array
        Points (``d >= 2``), the vertices of a full-dimensional polytope.

    Raises
    ------
    SolverError
        When qhull's hull fails the check.
    """
    from ._hull_cycle import checked_hull  # noqa: PLC0415

    checked = checked_hull(Y)
    if isinstance(checked, str):
        raise SolverError("volume of a convex hull", "qhull", f"its hull failed the check: {checked}",
                          hint="the vertices may be nearly flat; use method='monte-carlo'")
    return checked.volume


_MC_BATCH = 65536  # samples per vectorised membership call: bounded memory, negligible overhead
