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
from .section import _QUICK, ReportSection, SectionBuilder, ordered_sections
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
    return [k for k, _ in ordered_sections()]


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
        out = assemble_report(out_dir, [(k, b) for k, b in ordered_sections() if not only or k in only], progress, title=title)
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
            ok, err = not section.error, section.error
        except HybobsError as exc:
            section = ReportSection(key, f"<p class='error'>This section failed: {html.escape(str(exc))}</p>")
            ok, err = False, str(exc)
        seconds = time.perf_counter() - t0
        parts.append(f"<section id='{key}'><h2>{html.escape(section.title)}</h2>\n"
                     f"{wrap_tables(anchor_subheadings(key, section.body_html))}</section>")
        records.append(
            {"key": key, "title": section.title, "ok": ok, "error": err, "summary": section.summary,
             "figures": section.figures, "seconds": round(seconds, 3)}
        )
    index = out / "index.html"
    write_output_text(index, _PAGE.format(toc=table_of_contents(parts), body="\n".join(parts),
                                          stamp=time.strftime("%Y-%m-%d %H:%M:%S"), title=html.escape(title)))
    write_output_text(out / "summary.json", json.dumps({"sections": records}, indent=2))
    return {"index": str(index), "sections": records}


_HEADING = re.compile(r"<(h[23])(\s[^>]*)?>(.*?)</\1>", re.DOTALL)
_SECTION = re.compile(r"<section id='([^']+)'>")


def anchor_subheadings(key: str, body: str) -> str:
    """Give every ``<h3>`` of section ``key``'s ``body`` an id (``key-1``, ``key-2`` ...) for the contents.

    Parameters
    ----------
    key : str
        The section's key (its own anchor).
    body : str
        The section's HTML.

    Returns
    -------
    str
        ``body`` with ``<h3 id='key-i'>`` in place of each ``<h3>`` that has no attributes.
    """
    count = iter(range(1, 10_000))
    return re.sub(r"<h3>", lambda m: f"<h3 id='{key}-{next(count)}'>", body)


def table_of_contents(parts: list[str]) -> str:
    """The nested list of links of the contents: each section (``<h2>``) with its ``<h3>`` headings.

    Parameters
    ----------
    parts : list of str
        The sections' HTML, each ``<section id='key'><h2>title</h2>...`` with ids on its ``<h3>``.

    Returns
    -------
    str
        ``<ol>`` of ``<li><a href='#key'>title</a><ol>...</ol></li>``.
    """
    items = []
    for part in parts:
        key = _SECTION.match(part).group(1)
        heads = [(tag, attrs or "", text) for tag, attrs, text in _HEADING.findall(part)]
        title = next((text for tag, _, text in heads if tag == "h2"), key)
        subs = [(re.search(r"id='([^']+)'", attrs), text) for tag, attrs, text in heads if tag == "h3"]
        sub = "".join(f"<li><a href='#{m.group(1)}'>{text}</a></li>" for m, text in subs if m)
        items.append(f"<li><a href='#{key}'>{title}</a>" + (f"<ol>{sub}</ol>" if sub else "") + "</li>")
    return "<ol>" + "".join(items) + "</ol>"


#: The page: a contents sidebar that stays in view (``position: sticky``) beside the sections; below
#: 900 px wide the contents sit above the text.  The text column takes what the sidebar leaves
#: (``minmax(0, 1fr)``: a wide table scrolls in its own ``.table-wrap`` instead of widening it).
_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
* {{ box-sizing: border-box; }}
html {{ scroll-behavior: auto; }}
body {{ font-family: system-ui, sans-serif; margin: 0; color: #222; line-height: 1.45; }}
.layout {{ display: grid; grid-template-columns: 15rem minmax(0, 1fr); gap: 1.5rem; max-width: 1500px;
          margin: 0 auto; padding: 0 1.5rem; }}
nav.toc {{ position: sticky; top: 0; align-self: start; max-height: 100vh; overflow-y: auto;
           padding: 1rem 0.5rem 1rem 0; font-size: 0.85em; border-right: 1px solid #ddd; }}
nav.toc p {{ font-weight: bold; margin: 0 0 0.5em 0; }}
nav.toc ol {{ margin: 0; padding-left: 1.2em; }}
nav.toc ol ol {{ list-style: disc; padding-left: 1em; font-size: 0.95em; }}
nav.toc li {{ margin: 0.2em 0; }}
nav.toc a {{ color: #1a4f8b; text-decoration: none; }}
nav.toc a:hover {{ text-decoration: underline; }}
main {{ min-width: 0; padding: 1rem 0 4rem 0; }}
section, h3 {{ scroll-margin-top: 0.5rem; }}
h2 {{ border-top: 2px solid #ccc; padding-top: 0.8em; margin-top: 2em; }}
table {{ border-collapse: collapse; margin: 0; }}
.table-wrap {{ overflow-x: auto; max-width: 100%; margin: 1em 0; }}
.table-wrap .table-wrap {{ margin: 0; }}
table.matrix td {{ border: none; padding: 0 0.5em; text-align: right; font-variant-numeric: tabular-nums; }}
table.matrix {{ border-left: 1px solid #666; border-right: 1px solid #666; }}
figure {{ margin: 1em 0; }}
figcaption {{ font-size: 0.9em; color: #444; }}
td, th {{ border: 1px solid #ccc; padding: 0.3em 0.45em; font-size: 0.85em; vertical-align: top; }}
th {{ background: #f2f2f2; text-align: left; font-weight: 600; font-size: 0.8em; }}
td {{ font-variant-numeric: tabular-nums; }}
img {{ max-width: 100%; }}
.error {{ color: #a00; }}
code {{ background: #f6f6f6; padding: 0 0.2em; }}
@media (max-width: 900px) {{
  .layout {{ display: block; padding: 0 1rem; }}
  nav.toc {{ position: static; max-height: none; border-right: none; border-bottom: 1px solid #ddd; }}
}}
</style></head><body>
<div class="layout">
<nav class="toc" aria-label="Contents"><p>Contents</p>{toc}</nav>
<main>
<h1>{title}</h1>
<p>Generated {stamp}. Every number below is recomputed from the models by the toolbox.</p>
{body}
</main>
</div>
</body></html>
"""
