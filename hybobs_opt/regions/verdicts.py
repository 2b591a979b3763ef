"""The vocabularies of the observability regions (paper 002): pair verdicts and point classes.

Both are :class:`enum.StrEnum`: each member equals the string the toolbox has always used
(``PointClass.OBSERVABLE == "observable"``), ``str()``, f-strings and ``json.dumps`` give that
string, so the JSON records, saved files and printed text are unchanged.
"""

from __future__ import annotations

import enum


class PairVerdict(enum.StrEnum):
    """What :func:`~hybobs_opt.regions.pair_geometry.classify_pair` decides for one projection of a pair set ``R_ij``.

    ``PIECE`` is a piece of ``B_T``; the others are left out of it: the closed set is
    ``EMPTY``, its projection is ``LOWER_DIMENSIONAL`` (rank or certified thin), or the outputs
    force ``x^ = x`` on it (``SAME_STATE``).
    """

    EMPTY = "empty"
    LOWER_DIMENSIONAL = "lower-dimensional"
    SAME_STATE = "same state"
    PIECE = "piece"


class PointClass(enum.StrEnum):
    """The answer of the exact point query :meth:`~hybobs_opt.regions.ObservabilityAnalysis.classify`.

    ``OBSERVABLE``: in ``O_T`` (Definition 2.2); ``UNOBSERVABLE``: in ``B_T``; ``INFEASIBLE``:
    outside ``X*_T`` (no input sequence keeps the trajectory in the domain).  The labels of a
    :class:`~hybobs_opt.regions.Cut` are these members, in this order in :data:`~hybobs_opt.regions.cuts.LABELS`.
    """

    OBSERVABLE = "observable"
    UNOBSERVABLE = "unobservable"
    INFEASIBLE = "infeasible"


__all__ = ["PairVerdict", "PointClass"]
