"""Sphinx extension of the hybobs_opt documentation.

* ``.. hybobs-cli::`` -- the command-line reference, generated from the argparse parser of
  :func:`hybobs_opt.cli.build_parser` (one section per command and sub-command, with its usage and
  options exactly as ``hybobs CMD --help`` prints them);
* ``.. hybobs-cli-options::`` -- one table per command of every option with the kind of value it
  takes (:mod:`hybobs_opt.cli._vocabulary`), its default and its help, from the same parser (the old
  spellings kept as hidden aliases are not listed);
* ``.. hybobs-model-schema::`` -- the model-file format, rendered from
  ``hybobs_opt/systems/model.schema.json`` (one table of fields per object of the schema);
* at ``builder-inited``: the notebooks of ``notebooks/`` are copied to ``docs/_notebooks`` (myst-nb
  renders their stored outputs) and the study figures are drawn into ``docs/_generated`` by calling
  the studies' own functions with matplotlib's Agg backend (each the cheapest scenario of its paper,
  a few seconds in all).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

LOG = logging.getLogger(__name__)
DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent


# --------------------------------------------------------------------------------------------- CLI
def _subcommands(parser: argparse.ArgumentParser):
    """``(name, help, subparser)`` of each sub-command of ``parser``, in the parser's order."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name) or "", sub


def _help_text(parser: argparse.ArgumentParser) -> str:
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        return parser.format_help()
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


def _literal(text: str) -> list[str]:
    return ["", ".. code-block:: text", ""] + ["   " + line if line else "" for line in text.rstrip().splitlines()] + [""]


_UNDERLINES = "=-~^\"'"


def _cli_rst(parser: argparse.ArgumentParser, prog: str, level: int, summary: str = "") -> list[str]:
    title = f"``{prog}``"
    lines = [f".. _cli-{prog.replace(' ', '-')}:", "", title, _UNDERLINES[level] * len(title), ""]
    if summary:
        lines += [summary.replace("%%", "%"), ""]
    lines += _literal(_help_text(parser))
    for name, helptext, sub in _subcommands(parser):
        lines += _cli_rst(sub, f"{prog} {name}", level + 1, helptext)
    return lines


class CLIDirective(SphinxDirective):
    """The whole ``hybobs`` command tree, one section per command (section level of the page + 1)."""

    has_content = False

    def run(self):
        from hybobs_opt.cli import build_parser

        parser = build_parser()
        lines = _literal(_help_text(parser))
        for name, helptext, sub in _subcommands(parser):
            lines += _cli_rst(sub, f"hybobs {name}", 1, helptext)
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source="hybobs_opt.cli.build_parser"), node)
        return node.children


def _rst_text(text: str) -> str:
    """Plain text safe inside a table cell (no markup: ``*``, backquotes, ``|`` and ``_`` escaped)."""
    text = " ".join(str(text).replace("%%", "%").split())
    for char in ("\\", "*", "`", "|", "_"):
        text = text.replace(char, "\\" + char)
    # options as literals: no smart dashes ("--out" would become an en dash)
    return re.sub(r"(?<![\w-])(--?[A-Za-z][\w-]*)(?=[\s.,:;!?/'\")\]}]|$)", lambda m: f"``{m.group(1).replace(chr(92), '')}``", text)


def _option_rows(sub: argparse.ArgumentParser) -> list[tuple[str, str, str, str]]:
    """``(option, kind, default, help)`` of each option ``sub --help`` lists."""
    from hybobs_opt.cli._vocabulary import KIND_DESCRIPTIONS, option_kind, visible_options

    rows = []
    for action in visible_options(sub):
        kind = option_kind(action)
        base = kind.replace(" (repeatable)", "")
        text = KIND_DESCRIPTIONS[base]
        if base == "choice":
            text = "one of " + ", ".join(f"``{c}``" for c in action.choices)
        elif base in ("assignment", "range", "grid"):
            text = f"``{action.metavar}``"
        elif base != "flag":
            text += f" (``{action.metavar}``)"
        if kind.endswith("(repeatable)"):
            text += ", repeatable"
        if action.required:
            default = "required"
        elif action.nargs == 0 or action.default in (None, argparse.SUPPRESS):
            default = ""
        else:
            default = f"``{action.default}``"
        helptext = action.help() if callable(action.help) else (action.help or "")
        rows.append((", ".join(f"``{o}``" for o in action.option_strings), text, default, _rst_text(helptext)))
    return rows


def _options_rst(parser: argparse.ArgumentParser) -> list[str]:
    lines: list[str] = []
    for name, _, sub in _subcommands(parser):
        rows = _option_rows(sub)
        title = f"``hybobs {name}``"
        lines += [f".. rubric:: {title}", "", ".. list-table::", "   :header-rows: 1", "   :widths: 18 20 10 52", "",
                  "   * - Option", "     - Value", "     - Default", "     - What it does"]
        for row in rows:
            lines += [f"   * - {row[0]}"] + [f"     - {cell}" if cell else "     -" for cell in row[1:]]
        lines.append("")
    return lines


class CLIOptionsDirective(SphinxDirective):
    """One table per command: every option, the kind of value it takes, its default and its help."""

    has_content = False

    def run(self):
        from hybobs_opt.cli import build_parser

        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(_options_rst(build_parser()), source="hybobs_opt.cli.build_parser"),
                                 node)
        return node.children


# ---------------------------------------------------------------------------------- model schema
def _type(schema: dict) -> str:
    """A short, readable type of a JSON-Schema node (``$ref`` becomes a link to its table)."""
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f":ref:`{name} <schema-{name}>`"
    if "const" in schema:
        return f"``{json.dumps(schema['const'])}``"
    if "enum" in schema:
        return "one of " + ", ".join(f"``{json.dumps(v)}``" for v in schema["enum"])
    for key in ("oneOf", "anyOf"):
        if key in schema and all(isinstance(s, dict) and ("type" in s or "$ref" in s or "enum" in s or "const" in s)
                                 for s in schema[key]):
            return " or ".join(_type(s) for s in schema[key])
    kind = schema.get("type")
    if isinstance(kind, list):
        return " or ".join(kind)
    if kind == "array":
        items = schema.get("items")
        text = f"array of {_type(items)}" if isinstance(items, dict) and items else "array"
        bounds = [f"{schema['minItems']}" if "minItems" in schema else "", f"{schema['maxItems']}" if "maxItems" in schema else ""]
        if any(bounds):
            text += f" ({bounds[0] or 0}..{bounds[1] or 'n'} items)"
        return text
    if kind == "object":
        extra = schema.get("additionalProperties")
        if isinstance(extra, dict) and extra:
            return f"object of {_type(extra)}"
        return "object"
    if kind == "number" and "exclusiveMinimum" in schema:
        return f"number > {schema['exclusiveMinimum']}"
    if kind == "integer" and "minimum" in schema:
        return f"integer >= {schema['minimum']}"
    return kind or "any"


def _description(schema: dict) -> str:
    parts = [schema["description"]] if "description" in schema else []
    for key in ("oneOf", "anyOf"):
        for sub in schema.get(key, []):
            if isinstance(sub, dict) and "description" in sub:
                parts.append(sub["description"])
    items = schema.get("items")
    if isinstance(items, dict) and "description" in items:
        parts.append(items["description"])
    if "pattern" in schema:
        parts.append(f"matches the pattern {schema['pattern']}")
    return _escape("; ".join(parts).replace("\n", " "))


def _escape(text: str) -> str:
    """Plain schema text in reST: markup characters escaped."""
    for char in "\\*`|_":
        text = text.replace(char, "\\" + char)
    return text


def _rows(schema: dict, prefix: str = ""):
    """``(field, type, required, description)`` of an object node, nested objects flattened."""
    required = set(schema.get("required", ()))
    for name, sub in schema.get("properties", {}).items():
        field = f"{prefix}{name}"
        yield field, _type(sub), "yes" if name in required else "", _description(sub)
        items = sub.get("items") if sub.get("type") == "array" else None
        if isinstance(items, dict) and "properties" in items:
            yield from _rows(items, f"{field}[].")
        elif "properties" in sub:
            yield from _rows(sub, f"{field}.")


def _table(rows) -> list[str]:
    lines = ["", ".. list-table::", "   :header-rows: 1", "   :widths: 20 25 8 47", "",
             "   * - field", "     - type", "     - required", "     - description"]
    for field, kind, required, description in rows:
        lines += [f"   * - ``{field}``", f"     - {kind}", f"     - {required}", f"     - {description}"]
    return lines + [""]


def _combinations(schema: dict) -> list[str]:
    lines = []
    alternatives = [s.get("required") for s in schema.get("anyOf", []) if isinstance(s, dict) and "required" in s]
    if alternatives:
        lines += ["", "At least one of: " + "; ".join(" and ".join(f"``{f}``" for f in r) for r in alternatives) + "."]
    if schema.get("additionalProperties") is False or schema.get("unevaluatedProperties") is False:
        lines += ["", "No other fields, except comments: any field whose name starts with ``_`` is ignored."]
    return lines


class ModelSchemaDirective(SphinxDirective):
    """Tables of the model-file schema (top level, then each definition)."""

    def run(self):
        from hybobs_opt.systems.model_file import SCHEMA_PATH

        schema = json.loads(Path(SCHEMA_PATH).read_text(encoding="utf-8"))
        self.env.note_dependency(str(SCHEMA_PATH))
        lines = [_escape(schema.get("description", "")), "", "Top-level fields (every class):"]
        lines += _table(_rows(schema)) + _combinations(schema)
        classes = [c["if"]["properties"]["class"]["const"] for c in schema.get("allOf", []) if "if" in c]
        if classes:
            lines += ["", "The remaining fields depend on ``class``: "
                      + ", ".join(f":ref:`{c} <schema-{c}>`" for c in classes) + ".", ""]
        for name, sub in schema.get("$defs", {}).items():
            title = f"``{name}``" + (" (class)" if name in classes else "")
            lines += ["", f".. _schema-{name}:", "", title, "-" * len(title), ""]
            if "properties" in sub:
                if "description" in sub:
                    lines += [_escape(sub["description"]), ""]
                lines += _table(_rows(sub)) + _combinations(sub)
            else:
                lines += [f"Type: {_type(sub)}.", ""]
                if _description(sub):
                    lines += [_description(sub), ""]
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source=str(SCHEMA_PATH)), node)
        return node.children


# ------------------------------------------------------------------------------------- notebooks
def copy_notebooks(app) -> None:
    """``notebooks/*.ipynb`` -> ``docs/_notebooks`` (only files whose content changed are rewritten)."""
    target = DOCS / "_notebooks"
    target.mkdir(exist_ok=True)
    sources = sorted((ROOT / "notebooks").glob("*.ipynb"))
    names = {p.name for p in sources}
    for stale in target.glob("*.ipynb"):
        if stale.name not in names:
            stale.unlink()
    for src in sources:
        dst = target / src.name
        if not dst.exists() or dst.read_bytes() != src.read_bytes():
            shutil.copyfile(src, dst)


# --------------------------------------------------------------------------------------- figures
def _fig_paper000(path: Path) -> None:
    from hybobs_opt.studies.paper000_driveline.scenario import plot_fig6, run_driveline

    plot_fig6(run_driveline(), str(path))


def _fig_paper001(path: Path) -> None:
    from hybobs_opt.studies.paper001_sliding_mode.scenarios import _plot, run_scenario

    _plot(run_scenario("triangular"), str(path))


def _fig_paper002(path: Path) -> None:
    from hybobs_opt import analyse_observability, compute_cut, get_example
    from hybobs_opt.report.plots import plot_region_cut

    example = get_example("powertrain3")
    analysis = analyse_observability(example.build(), 3)
    plot_region_cut(compute_cut(analysis, {"omega_l": 25.0}), str(path),
                    title="model (16), T = 3: cut of O_T at omega_l = 25 rad/s (Fig. 3)",
                    units=dict(zip(example.state_names, example.state_units)))


def _fig_paper003(path: Path) -> None:
    from hybobs_opt.studies.paper003_switching.scenarios import plot_drift_run, run_drift_scenario

    plot_drift_run(run_drift_scenario("traffic_junction"), str(path), title="T-junction (Section 5), gains (20a-b)")


def _fig_paper004(path: Path) -> None:
    import numpy as np

    from hybobs_opt import get_example
    from hybobs_opt.plotting import pyplot
    from hybobs_opt.studies.paper004_nonmonotonic.scenarios import run_example

    trace, out, summary = run_example("vehicle_tracking")
    plt = pyplot()
    names = out.state_names or tuple(f"x{i}" for i in range(trace.x.shape[1]))
    n = len(trace.t)
    fig, axes = plt.subplots(len(names), 1, figsize=(7, 1.8 * len(names)), sharex=True)
    for i, ax in enumerate(np.atleast_1d(axes)):
        ax.plot(trace.t, trace.x[:n, i], "k", lw=1.2, label="true")
        ax.plot(trace.t, out.x_hat[:n, i], "C1--", lw=1.0, label="switched-gain estimate")
        ax.set_ylabel(get_example("vehicle_tracking").state_label(names[i]) if names[i] in
                      get_example("vehicle_tracking").state_names else names[i])
    np.atleast_1d(axes)[0].legend(loc="best", fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("t [s]")
    fig.suptitle(f"vehicle tracking: {summary.get('n_switches', '?')} gain switches, "
                 f"converged at t = {summary.get('convergence_time', float('nan')):.2f} s")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


FIGURES = {
    "paper000_fig6.png": _fig_paper000,
    "paper001_triangular.png": _fig_paper001,
    "paper002_cut.png": _fig_paper002,
    "paper003_junction.png": _fig_paper003,
    "paper004_vehicle.png": _fig_paper004,
}


def draw_figures(app) -> None:
    """Draw the study figures into ``docs/_generated`` (skipped when ``hybobs_figures`` is False)."""
    target = DOCS / "_generated"
    target.mkdir(exist_ok=True)
    if not app.config.hybobs_figures:
        return
    import matplotlib

    matplotlib.use("Agg", force=True)
    for name, draw in FIGURES.items():
        path = target / name
        draw(path)
        if not path.exists():
            raise RuntimeError(f"the study figure {name} was not written")
        LOG.info("hybobs_docs: drew %s", name)


def setup(app):
    app.add_config_value("hybobs_figures", True, "env")
    app.add_directive("hybobs-cli", CLIDirective)
    app.add_directive("hybobs-cli-options", CLIOptionsDirective)
    app.add_directive("hybobs-model-schema", ModelSchemaDirective)
    app.connect("builder-inited", copy_notebooks)
    app.connect("builder-inited", draw_figures)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}

