"""Built-in report sections (registered on import)."""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..studies import PAPERS, list_examples
from .section import ReportSection, register_section
from .plots import plot_trace


def examples_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Every example of the seed papers, simulated on its paper's scenario."""
    rows, figs, summary, alts = [], [], {}, {}
    for ex in list_examples():
        progress(f"examples/{ex.name}")
        trace = ex.simulate()
        fig = f"example_{ex.name}.png"
        plot_trace(trace, out / fig, title=f"{ex.name} (paper {ex.paper})", units=ex.state_units)
        figs.append(fig)
        alts[fig] = (f"Simulation of {ex.name} (paper {ex.paper}) over {trace.t[-1] - trace.t[0]:g} s: "
                     + ", ".join(ex.state_label(nm) for nm in ex.state_names)
                     + f" against time, and the location q ({len(set(trace.q.tolist()))} visited)")
        n_changes = int(np.count_nonzero(np.diff(trace.q)))
        summary[ex.name] = {"samples": trace.n_samples, "discrete_changes": n_changes}
        rows.append(
            f"<tr><td><code>{ex.name}</code></td><td>{ex.kind}</td><td>{ex.paper}</td><td>{ex.n_states}</td>"
            f"<td>{html.escape(', '.join(ex.state_label(nm) for nm in ex.state_names))}</td><td>{n_changes}</td><td>{html.escape(ex.summary)}</td></tr>"
        )
    table = (
        "<table><tr><th>name</th><th>kind</th><th>paper</th><th>n</th><th>states</th>"
        "<th>discrete changes in scenario</th><th>summary</th></tr>" + "".join(rows) + "</table>"
    )
    papers = "<ul>" + "".join(f"<li><b>{k}</b>: {html.escape(v)}</li>" for k, v in PAPERS.items()) + "</ul>"
    images = "".join(f"<h3>{html.escape(f[8:-4])}</h3><img src='{f}' alt='{html.escape(alts[f], quote=True)}'>" for f in figs)
    return ReportSection("Example systems of the seed papers", papers + table + images, summary, figs)


register_section("examples", examples_section)

from . import regions_section  # noqa: E402,F401
from . import lmi_section  # noqa: E402,F401
from . import driveline_section  # noqa: E402,F401
from . import drift_section  # noqa: E402,F401
from . import sliding_section  # noqa: E402,F401
from . import observers_section  # noqa: E402,F401
