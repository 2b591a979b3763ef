"""Tables, plots and HTML reports built from results (the ``hybobs report`` command)."""

from .html import ReportSection, build_report, register_section
from .plots import plot_region_cut, plot_trace

__all__ = ["ReportSection", "build_report", "plot_region_cut", "plot_trace", "register_section"]
