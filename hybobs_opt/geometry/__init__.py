"""Geometry, the lowest core layer: H-polytopes and the LPs every set computation goes through.

:mod:`~hybobs_opt.geometry.lp` (the checked LP layer: :func:`solve_lp`, :func:`row_range`, the
certified max-slack LPs), :mod:`~hybobs_opt.geometry.polytope` (the :class:`Polytope` type),
:mod:`~hybobs_opt.geometry.redundancy`, :mod:`~hybobs_opt.geometry.projection` and
:mod:`~hybobs_opt.geometry.volume`.  Names are imported on first use.
"""

from .._lazy import lazy_exports

_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("LPCounters", "LPResult", "SlackResult", "certified_width_below", "counting_lps", "max_slack",
                     "row_range", "solve_lp", "solve_slack_lp", "verified_lp"), "hybobs_opt.geometry.lp"),
    "Polytope": "hybobs_opt.geometry.polytope",
    "polytope_difference": "hybobs_opt.geometry.difference",
    **dict.fromkeys(("VolumeEstimate", "monte_carlo_volume"), "hybobs_opt.geometry.volume"),
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = sorted(_EXPORTS)
