"""One section of the report and the registry of section builders.

A section module builds a :class:`ReportSection` and calls :func:`register_section`;
:func:`hybobs_opt.report.html.build_report` assembles the registered sections into the page.
"""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SectionBuilder = Callable[[Path, Callable[[str], None]], "ReportSection"]


@dataclass
class ReportSection:
    """One section of the report: a title, an HTML body, and a JSON-ready summary.

    See Also
    --------
    register_section : adds a section builder to the report.
    build_report : builds the report.

    Examples
    --------
    >>> from hybobs_opt.report import ReportSection
    >>> section = ReportSection("Hello", "<p>One paragraph.</p>", summary={"answer": 42})
    >>> section.title, section.summary, section.figures
    ('Hello', {'answer': 42}, [])
    """

    title: str
    body_html: str
    summary: dict[str, Any] = field(default_factory=dict)
    figures: list[str] = field(default_factory=list)
    #: Set when the section ran but could not do what it is for (its body says why): the report
    #: keeps the section and marks it not ``ok``, with this message as its ``error``.
    error: str = ""


_SECTIONS: list[tuple[str, SectionBuilder]] = []

#: The order of the built-in sections in the report.  Each registers when its module is imported,
#: and which module a process imports first depends on what it did before, so the report orders
#: them by this tuple, not by registration; sections registered by users follow, in their order.
BUILTIN_SECTION_ORDER: tuple[str, ...] = ("examples", "regions", "lmi", "vehicle_paper_design", "piston_comparison",
                                          "driveline_observer", "drift", "sliding_mode", "observers")


def ordered_sections() -> list[tuple[str, SectionBuilder]]:
    """The registered sections in report order: the built-in ones by :data:`BUILTIN_SECTION_ORDER`,
    then the others in the order they were registered.

    Returns
    -------
    list of (str, callable)
        ``(key, builder)`` pairs.

    Examples
    --------
    >>> from hybobs_opt.report.section import ordered_sections
    >>> isinstance(ordered_sections(), list)
    True
    """
    rank = {key: i for i, key in enumerate(BUILTIN_SECTION_ORDER)}
    return sorted(_SECTIONS, key=lambda item: (0, rank[item[0]]) if item[0] in rank else (1, 0))

#: Whether the report being built is the quick preview (``build_report(quick=True)``).
_QUICK: ContextVar[bool] = ContextVar("hybobs_report_quick", default=False)


def samples(full: int, quick: int) -> int:
    """A section's sample count: ``full`` in the report, ``quick`` in the quick preview
    (``build_report(quick=True)``, ``hybobs report --quick``): every table and figure, from fewer
    samples."""
    return quick if _QUICK.get() else full



def register_section(key: str, builder: SectionBuilder) -> None:
    """Add a section builder ``builder(out_dir, progress) -> ReportSection`` under ``key``.

    See Also
    --------
    ReportSection : what a builder returns.
    build_report : runs the builders.

    Examples
    --------
    A section of your own, built alone into a report directory:

    >>> import tempfile
    >>> from hybobs_opt.report import ReportSection, build_report, register_section
    >>> def hello(out_dir, progress):
    ...     return ReportSection("Hello", "<p>One paragraph.</p>", summary={"answer": 42})
    >>> register_section("hello", hello)
    >>> result = build_report(tempfile.mkdtemp(), only=["hello"])
    >>> [(s["key"], s["ok"], s["summary"]) for s in result["sections"]]
    [('hello', True, {'answer': 42})]
    """
    if any(k == key for k, _ in _SECTIONS):
        return
    _SECTIONS.append((key, builder))
