"""Tables, plots and HTML reports built from results (the ``hybobs report`` command)."""

from .html import build_report
from .plots import plot_region_cut, plot_trace
from .section import ReportSection, register_section

__all__ = ["ReportSection", "build_report", "plot_region_cut", "plot_trace", "register_section"]
