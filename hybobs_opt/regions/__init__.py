"""Observability regions of PWA systems from LP feasibility tests (paper 002, Sections 2-3).

``enumerate_modes`` builds the regions of eq. (4); ``analyse_observability`` runs Algorithm 3.1
(``I``, ``B_T``, ``B~_T``) and answers exact point queries; ``compute_cut`` classifies 2-D cuts;
``save_analysis`` / ``load_analysis`` keep the result for the lookup observer.  ``PairVerdict``
and ``PointClass`` are the string-valued vocabularies of the pair tests and the point queries.
"""

from .cuts import Cut, compute_cut, parse_assignments, plot_cut
from .enumeration import ModeEnumeration, ModeRegion, enumerate_modes
from .io import load_analysis, save_analysis
from .observability import ObservabilityAnalysis, analyse_observability
from .pair_sets import PairList, PairSet, PairSets
from .verdicts import PairVerdict, PointClass

__all__ = [
    "Cut",
    "ModeEnumeration",
    "ModeRegion",
    "ObservabilityAnalysis",
    "PairList",
    "PairSet",
    "PairSets",
    "PairVerdict",
    "PointClass",
    "analyse_observability",
    "compute_cut",
    "enumerate_modes",
    "load_analysis",
    "parse_assignments",
    "plot_cut",
    "save_analysis",
]
