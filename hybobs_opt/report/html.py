"""The HTML report: a list of sections, each contributing HTML and PNG figures.

Each section module (the example systems, the observability regions, the observers, the LMI
diagnostics ...) registers its builder with :func:`~hybobs_opt.report.section.register_section`.
"""

from __future__ import annotations

import html
import json
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import HybobsError, ModelError
from .section import _QUICK, _SECTIONS, ReportSection, SectionBuilder
from .._output_files import write_output_text

def wrap_tables(body: str) -> str:
    """Wrap every ``<table>`` of ``body`` in a ``<div class='table-wrap'>`` that scrolls sideways.

    A wide table (the 13-column observer tables) then scrolls inside the page instead of making
    the page itself wider than the window.

    Parameters
    ----------
    body : str
        HTML.

    Returns
    -------
    str
    """
    body = re.sub(r"<table\b", "<div class='table-wrap'><table", body)
    return body.replace("</table>", "</table></div>")


def section_keys() -> list[str]:
    _load_builtin_sections()
    return [k for k, _ in _SECTIONS]


def _load_builtin_sections() -> None:
    from . import sections  # noqa: F401  registers the built-in sections


def build_report(out_dir: str | Path, progress: Callable[[str], None] | None = None, only: list[str] | None = None,
                 *, quick: bool = False) -> dict[str, Any]:
    """Build ``out_dir/index.html`` (with PNG figures) from every registered section.

    A section that fails is reported in the page with its error instead of aborting the report.

    Parameters
    ----------
    out_dir : str or Path
        Directory of ``index.html``, ``summary.json`` and the figures (created if missing).
    progress : callable, optional
        Called with the key of each section (and of its phases) as it starts.
    only : list of str, optional
        Keys of the sections to build (:func:`section_keys`); default every one.
    quick : bool, default False
        A preview: every section, table and figure, from fewer samples (shorter runs, coarser
        grids, fewer timing repeats), about a third of the time.  The page says so in its title.

    Returns
    -------
    dict
        ``{"index": path, "quick": bool, "sections": [{"key", "title", "ok", "summary", "figures", "seconds"}]}``

    See Also
    --------
    register_section : add a section.
    ReportSection : one section's content.

    Examples
    --------
    The whole report is ``hybobs report --out-dir DIR``; ``only`` builds some sections:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.report import ReportSection, build_report, register_section
    >>> register_section("greeting", lambda out_dir, progress: ReportSection("Greeting", "<p>Hi.</p>"))
    >>> out = Path(tempfile.mkdtemp())
    >>> result = build_report(out, only=["greeting"])
    >>> sorted(path.name for path in out.iterdir()), result["sections"][0]["ok"]
    (['index.html', 'summary.json'], True)
    """
    if not isinstance(quick, bool):
        raise ModelError("quick", "True or False", repr(quick))
    _load_builtin_sections()
    token = _QUICK.set(quick)
    try:
        title = "hybobs_opt report (quick preview: fewer samples)" if quick else "hybobs_opt report"
        out = assemble_report(out_dir, [(k, b) for k, b in _SECTIONS if not only or k in only], progress, title=title)
    finally:
        _QUICK.reset(token)
    return {**out, "quick": quick}


def assemble_report(out_dir: str | Path, builders: list[tuple[str, SectionBuilder]],
                    progress: Callable[[str], None] | None = None, title: str = "hybobs_opt report") -> dict[str, Any]:
    """Build ``out_dir/index.html`` and ``summary.json`` from ``builders`` (``[(key, builder)]``), in order."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    progress = progress or (lambda msg: None)
    parts, records = [], []
    for key, builder in builders:
        t0 = time.perf_counter()
        progress(key)
        try:
            section = builder(out, progress)
            ok, err = True, ""
        except HybobsError as exc:
            section = ReportSection(key, f"<p class='error'>This section failed: {html.escape(str(exc))}</p>")
            ok, err = False, str(exc)
        seconds = time.perf_counter() - t0
        parts.append(f"<section id='{key}'><h2>{html.escape(section.title)}</h2>\n{wrap_tables(section.body_html)}</section>")
        records.append(
            {"key": key, "title": section.title, "ok": ok, "error": err, "summary": section.summary,
             "figures": section.figures, "seconds": round(seconds, 3)}
        )
    index = out / "index.html"
    toc = "".join(f"<li><a href='#{r['key']}'>{html.escape(r['title'])}</a></li>" for r in records)
    write_output_text(index, _PAGE.format(toc=toc, body="\n".join(parts), stamp=time.strftime("%Y-%m-%d %H:%M:%S"),
                                  title=html.escape(title)))
    write_output_text(out / "summary.json", json.dumps({"sections": records}, indent=2))
    return {"index": str(index), "sections": records}


_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: system-ui, sans-serif; max-width: 1000px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 0; }}
.table-wrap {{ overflow-x: auto; max-width: 100%; margin: 1em 0; }}
figure {{ margin: 1em 0; }}
figcaption {{ font-size: 0.9em; color: #444; }}
td, th {{ border: 1px solid #ccc; padding: 0.3em 0.6em; font-size: 0.9em; }}
th {{ background: #f2f2f2; }}
img {{ max-width: 100%; }}
.error {{ color: #a00; }}
code {{ background: #f6f6f6; padding: 0 0.2em; }}
</style></head><body>
<h1>{title}</h1>
<p>Generated {stamp}. Every number below is recomputed from the models by the toolbox.</p>
<ul>{toc}</ul>
{body}
</body></html>
"""
