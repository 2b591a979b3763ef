"""Checks of what a reader of the built report sees: no Python literals in the text, every table
in a scrolling box, a unit in the header of every numeric column.

* :func:`visible_text` is the page as read (tags, scripts, styles and attribute values dropped,
  entities decoded); :func:`literal_problems` finds in it the spellings of Python values that
  are not words: ``True``/``False``/``None``, numpy reprs (``array(``, ``[[``), the code's
  UPPER_CASE constant names, and floats printed with their full binary precision.
* :func:`table_problems` reports a ``<table>`` outside a ``<div class='table-wrap'>`` and a
  header of a numeric column that names no unit (``[s]``, ``[rad/s]``, ``[samples]`` ...) and is
  not in :data:`DIMENSIONLESS_HEADERS`.

Pure standard library, no browser: the report tests run it on the built page and on single
sections.  ``python -m tests.check_report_text DIR`` checks ``DIR/index.html``.
"""

from __future__ import annotations

import ast
import html
import re
import sys
from functools import lru_cache
from html.parser import HTMLParser
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent.parent / "hybobs_opt"

#: Headers of numeric columns that carry no unit: ratios, condition numbers and relative errors,
#: indices (model, equation, region and phase numbers), and counts whose header says what they
#: count.  A header may also say ``(dimensionless)`` or name its unit in brackets.
DIMENSIONLESS_HEADERS = frozenset({
    # ratios, relative errors, condition numbers
    "cond P", "kappa(H)", "||C|| sqrt(cond P)", "||C P^-1/2|| ||P^1/2||", "ratio here/paper", "median step / lookup's",
    "monodromy radius", "gear ratio", "noise / range", "S_o != S fraction", "largest relative error after it",
    "max relative error where flagged observable", "max Mahalanobis distance where flagged",
    # indices
    "model", "paper", "region", "phase j", "leaves mode v_j",
    # counts
    "n", "regions", "|I| (full-rank regions)", "pieces of B_T", "pieces of B~_T", "LPs", "discrete changes in scenario",
    "dim M", "dim non-transverse", "dim S", "dim L", "spurious switches", "true switches",
})

#: A unit (or what a count counts) in brackets at the end of a header: ``t [s]``, ``T [samples]``.
_UNIT = re.compile(r"\[[^\]]+\]\s*$")

#: A cell of a numeric column: numbers (possibly several, separated by commas or slashes), with signs, exponents,
#: ``inf`` and the words used for a missing value.
_NUMBER = r"[-+]?(?:\d+(?:[.,]\d+)*(?:\.\d*)?(?:e[-+]?\d+)?|inf)"
_NUMERIC_CELL = re.compile(rf"^\s*{_NUMBER}(?:\s*[,/]\s*{_NUMBER})*\s*$", re.IGNORECASE)
_MISSING = {"", "-", "n/a", "never", "none", "not reached"}


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.parts: list[str] = []
        self._skip = 0

    def handle_starttag(self, tag: str, attrs) -> None:
        if tag in ("script", "style", "title"):
            self._skip += 1
        elif tag in ("p", "li", "td", "th", "tr", "h1", "h2", "h3", "h4", "div", "br", "figcaption", "pre"):
            self.parts.append("\n")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("script", "style", "title"):
            self._skip = max(0, self._skip - 1)

    def handle_data(self, data: str) -> None:
        if not self._skip:
            self.parts.append(data)


def visible_text(page: str) -> str:
    """The text of ``page`` a reader sees: no tags, scripts, styles or attributes; entities decoded."""
    p = _Text()
    p.feed(page)
    p.close()
    return html.unescape("".join(p.parts))


@lru_cache(maxsize=1)
def code_constant_names() -> frozenset[str]:
    """The UPPER_CASE names assigned at module or class level anywhere in ``hybobs_opt``."""
    names: set[str] = set()
    for path in _PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bodies = [tree.body] + [n.body for n in ast.walk(tree) if isinstance(n, ast.ClassDef)]
        for body in bodies:
            for node in body:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
                for t in targets:
                    for el in (t.elts if isinstance(t, ast.Tuple) else [t]):
                        if isinstance(el, ast.Name) and re.fullmatch(r"[A-Z][A-Z0-9_]*", el.id) and len(el.id) >= 4:
                            names.add(el.id)
    return frozenset(names)


#: Python spellings that are not words of a sentence.
_LITERALS = [
    (re.compile(r"\barray\("), "a numpy array repr"),
    (re.compile(r"\[\s*\["), "a nested list or matrix repr"),
    (re.compile(r"\b[A-Z][A-Z0-9]*(?:_[A-Z0-9]+)*_[A-Z]{3,}[A-Z0-9_]*\b|\b[A-Z]{3,}[A-Z0-9]*_[A-Z0-9_]+\b"),
     "an UPPER_CASE identifier"),
    (re.compile(r"(?<![\w.])\d*\.\d{8,}"), "a float printed at full precision"),
]


def _python_literals(text: str) -> list[re.Match]:
    """``True``/``False``/``None`` except as the first word of a sentence ("True system from x(0) ...")."""
    out = []
    for m in re.finditer(r"\b(True|False|None)\b", text):
        before = text[:m.start()].rstrip(" ")
        sentence_start = before == "" or before[-1] in "\n.!?"
        if sentence_start and re.match(r" +[a-z]", text[m.end():]):
            continue
        out.append(m)
    return out


def literal_problems(text: str) -> list[str]:
    """Python spellings in ``text`` (see the module docstring), one line each with its context."""
    problems = []
    found = [(m, why) for rx, why in _LITERALS for m in rx.finditer(text)]
    found += [(m, "a Python literal") for m in _python_literals(text)]
    constants = code_constant_names()
    found += [(m, "a constant name of the code") for m in re.finditer(r"\b[A-Z][A-Z0-9_]{3,}\b", text)
              if m.group(0) in constants]
    seen = set()
    for m, why in sorted(found, key=lambda mw: mw[0].start()):
        if m.start() in seen:
            continue
        seen.add(m.start())
        context = " ".join(text[max(0, m.start() - 50):m.end() + 30].split())
        problems.append(f"{why} {m.group(0)!r}: ...{context}...")
    return problems


class _Tables(HTMLParser):
    """Every table's header texts and cell texts (first row of ``<th>`` = header), and its wrapper."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[tuple[str, dict]] = []
        self.tables: list[dict] = []
        self._open: list[dict] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs) -> None:
        a = dict(attrs)
        if tag == "table":
            wrapped = any(t == "div" and "table-wrap" in (aa.get("class") or "").split() for t, aa in self.stack)
            self._open.append({"wrapped": wrapped, "rows": [], "nested": bool(self._open)})
        elif tag == "tr" and self._open:
            self._open[-1]["rows"].append([])
        elif tag in ("td", "th") and self._open:
            if not self._open[-1]["rows"]:
                self._open[-1]["rows"].append([])
            self._cell = []
            self._open[-1]["rows"][-1].append((tag, self._cell, a))
        self.stack.append((tag, a))

    def handle_endtag(self, tag: str) -> None:
        while self.stack and self.stack.pop()[0] != tag:
            pass
        if tag == "table" and self._open:
            self.tables.append(self._open.pop())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def tables_of(page: str) -> list[dict]:
    """``[{"wrapped": bool, "nested": bool, "rows": [[(tag, text, attrs)]]}]`` of every table."""
    p = _Tables()
    p.feed(page)
    p.close()
    for t in p.tables:
        t["rows"] = [[(tag, " ".join("".join(parts).split()), a) for tag, parts, a in row] for row in t["rows"]]
    return p.tables


def numeric_columns_without_unit(table: dict) -> list[str]:
    """Headers of ``table``'s numeric columns that name no unit and are not dimensionless."""
    rows = table["rows"]
    if not rows or not all(tag == "th" for tag, _, _ in rows[0]) or len(rows) < 2:
        return []  # no header row (a matrix, a key/value list)
    header = [text for _, text, _ in rows[0]]
    bad = []
    for j, head in enumerate(header):
        cells = [row[j][1] for row in rows[1:] if len(row) == len(header) and row[j][0] == "td"]
        values = [c for c in cells if c.lower() not in _MISSING]
        if not values or not all(_NUMERIC_CELL.match(c) for c in values):
            continue
        if _UNIT.search(head) or head in DIMENSIONLESS_HEADERS or "(dimensionless)" in head:
            continue
        bad.append(head)
    return bad


def table_problems(page: str) -> list[str]:
    """Tables outside a scrolling wrapper and numeric columns whose header names no unit."""
    problems = []
    for i, t in enumerate(tables_of(page)):
        first = " | ".join(text for _, text, _ in (t["rows"][0] if t["rows"] else []))[:80]
        if not t["wrapped"]:
            problems.append(f"table {i} ({first}) is not inside a div.table-wrap")
        problems += [f"table {i} ({first}): numeric column {h!r} names no unit" for h in numeric_columns_without_unit(t)]
    return problems


def main(argv: list[str] | None = None) -> int:
    """Check ``DIR/index.html`` for each ``DIR``; print one line per problem; exit status 1 if any."""
    problems = []
    for d in (argv if argv is not None else sys.argv[1:]):
        page = (Path(d) / "index.html").read_text(encoding="utf-8")
        problems += literal_problems(visible_text(page)) + table_problems(page)
    print("\n".join(problems))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
