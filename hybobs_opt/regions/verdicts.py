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

    See Also
    --------
    PairSet : a pair kept as a piece of ``B_T``.

    Examples
    --------
    >>> from hybobs_opt.regions import PairVerdict
    >>> [verdict.value for verdict in PairVerdict]
    ['empty', 'lower-dimensional', 'same state', 'piece']
    >>> PairVerdict("piece") is PairVerdict.PIECE
    True
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

    See Also
    --------
    ObservabilityAnalysis.classify : returns one.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> from hybobs_opt.regions import PointClass
    >>> analysis.classify(np.array([0.06, 39.0, 3.25])) is PointClass.OBSERVABLE
    True
    >>> [label.value for label in PointClass]
    ['observable', 'unobservable', 'infeasible']
    """

    OBSERVABLE = "observable"
    UNOBSERVABLE = "unobservable"
    INFEASIBLE = "infeasible"


__all__ = ["PairVerdict", "PointClass"]
