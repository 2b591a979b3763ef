"""What a reader of the report sees: the contents sidebar, tables in scrolling boxes with units in
their headers, and words instead of Python values (issue 38).

The checker (:mod:`tests.check_report_text`) is tested here on small pages; the whole built report
is checked in ``test_report_figures.py`` (its module builds the report once), and two sections
that build in seconds are checked here on their own, assembled into a page.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.report.section import ReportSection
from tests.check_links import check_html_tree
from tests.check_report_text import (
    code_constant_names,
    literal_problems,
    table_problems,
    visible_text,
)

# ---------------------------------------------------------------------------- the checker


def test_visible_text_drops_tags_scripts_styles_and_attributes():
    page = ("<html><head><title>True</title><style>p { color: None }</style></head><body>"
            "<script>var x = [[1]];</script><p class='False'>a &lt; b</p><img alt='array(1)'></body></html>")
    assert visible_text(page).split() == ["a", "<", "b"]


@pytest.mark.parametrize("text, kind", [
    ("converged = True (at t = 1 s)", "Python literal"),
    ("at t = None s", "Python literal"),
    ("gain L = array([1., 2.])", "numpy array repr"),
    ("T = [[1.0, 0.0], [0.0, 1.0]]", "nested list"),
    ("at least MHE_UNIQUENESS_DELTA away", "UPPER_CASE"),
    ("the formulas (P_DERIVED) agree", "UPPER_CASE"),
    ("an error of 0.30000000000000004 rad", "full precision"),
])
def test_literal_problems_finds_each_kind(text, kind):
    problems = literal_problems(text)
    assert len(problems) == 1 and kind in problems[0], problems


def test_literal_problems_passes_prose_and_math_names():
    text = ("The MIQP and MILP observers (MHE, LMI (8), RK4) flag 1187 of 1200 samples; B_T and B~_T have "
            "8 pieces, X*_5 is empty, O_7 was not obtained; true states are inside; none is outside; "
            "T = 3, a 0.1234 rad error, the paper's gain 42.1703.")
    assert literal_problems(text) == []


def test_code_constants_are_read_from_the_package():
    names = code_constant_names()
    assert {"MHE_UNIQUENESS_DELTA", "SMO_FILTER_STEPS", "P_DERIVED", "NOISE_STUDY_MHE_STEPS"} <= names
    assert literal_problems("the value of SMO_FILTER_STEPS") != []


def test_table_problems_unwrapped_tables_and_headers_without_units():
    good = ("<div class='table-wrap'><table><tr><th>observer</th><th>median step [ms]</th><th>cond P</th>"
            "<th>RMS error (dimensionless)</th><th>note</th></tr>"
            "<tr><td>lookup</td><td>0.01234</td><td>12.5</td><td>1.2e-05</td><td>3 regions</td></tr>"
            "<tr><td>miqp</td><td>n/a</td><td>inf</td><td>0.5, 0.25</td><td>-</td></tr></table></div>")
    assert table_problems(good) == []
    bad = ("<table><tr><th>observer</th><th>median step</th></tr><tr><td>lookup</td><td>0.0123</td></tr></table>"
           "<div class='table-wrap'><table><tr><th>delay</th><th>name</th></tr><tr><td>-1.5e-3</td><td>a</td></tr></table></div>")
    problems = table_problems(bad)
    assert len(problems) == 3, problems
    assert "not inside a div.table-wrap" in problems[0]
    assert "'median step' names no unit" in problems[1] and "'delay' names no unit" in problems[2]


def test_a_matrix_in_a_cell_is_a_wrapped_table_without_header():
    page = ("<div class='table-wrap'><table><tr><th>region</th><th>gain L</th></tr><tr><td>1</td><td>"
            "<div class='table-wrap'><table class='matrix'><tr><td>1</td><td>2</td></tr></table></div>"
            "</td></tr></table></div>")
    assert table_problems(page) == []


# ---------------------------------------------------------------------------- the words for values


def test_values_read_as_words_and_rounded_numbers():
    from hybobs_opt.report.text import matrix_table, num, vector, yes_no

    assert [yes_no(True), yes_no(np.bool_(False)), yes_no(None)] == ["yes", "no", "n/a"]
    assert [num(3.14159265), num(-0.000123456), num(123456.7), num(7), num(np.int64(12)), num(None), num(np.nan),
            num(-np.inf)] == ["3.142", "-0.0001235", "1.235e+05", "7", "12", "n/a", "n/a", "-inf"]
    assert num(2.0 / 3.0, 2) == "0.67"
    assert vector(np.array([1.0, 1.0 / 3.0])) == "(1, 0.3333)"
    m = matrix_table(np.array([[1.0, -2.0 / 3.0], [0.0, 1e-9]]), row_labels=["a", "b"], col_labels=["y1", "y2"])
    assert m.startswith("<table class='matrix'>")
    assert "<td>-0.6667</td>" in m and "<td>1e-09</td>" in m and "<td><i>b</i></td>" in m
    assert literal_problems(visible_text(m)) == []


@pytest.mark.parametrize("name, args, kwargs", [
    ("yes_no", (1,), {}), ("num", (True,), {}), ("num", ("1.5",), {}), ("vector", (["a"],), {}),
    ("matrix_table", (np.zeros((2, 2, 2)),), {}), ("matrix_table", (np.eye(2),), {"row_labels": ["a"]}),
])
def test_values_refuse_what_they_would_misprint(name, args, kwargs):
    import hybobs_opt.report.text as text

    with pytest.raises(ModelError):
        getattr(text, name)(*args, **kwargs)


# ---------------------------------------------------------------------------- the page


def _fake_section(title: str, body: str):
    return lambda out, progress: ReportSection(title, body)


def test_page_has_a_sticky_contents_sidebar_with_every_section_and_subheading(tmp_path):
    from hybobs_opt.report.html import assemble_report

    wide = "<table><tr>" + "".join(f"<th>column {i} [s]</th>" for i in range(20)) + "</tr><tr>" + "<td>1.5</td>" * 20 + "</tr></table>"
    res = assemble_report(tmp_path, [
        ("first", _fake_section("First & one", "<p>intro</p><h3>Part <code>a</code></h3><p>x</p><h3>Part b</h3>" + wide)),
        ("second", _fake_section("Second", "<p>no subheadings</p>")),
    ])
    page = (tmp_path / "index.html").read_text()
    nav = re.search(r"<nav class=\"toc\"[^>]*>(.*?)</nav>", page, re.DOTALL)
    assert nav, "no contents sidebar"
    links = re.findall(r"href='#([^']+)'", nav.group(1))
    assert links == ["first", "first-1", "first-2", "second"]
    assert "First &amp; one" in nav.group(1) and "Part <code>a</code>" in nav.group(1)
    assert "<h3 id='first-1'>Part <code>a</code></h3>" in page
    # the sidebar stays in view; the text column may shrink below a wide table's width
    css = re.search(r"<style>(.*?)</style>", page, re.DOTALL).group(1)
    assert re.search(r"nav\.toc\s*\{[^}]*position:\s*sticky;[^}]*top:\s*0", css)
    assert re.search(r"grid-template-columns:[^;]*minmax\(0,\s*1fr\)", css)
    assert re.search(r"@media \(max-width: \d+px\)\s*\{[^@]*nav\.toc\s*\{[^}]*position:\s*static", css)
    assert "<script" not in page and "http" not in page.split("<body>")[0]  # no JS, no CDN
    assert table_problems(page) == [] and check_html_tree(tmp_path) == []
    assert [s["key"] for s in res["sections"]] == ["first", "second"]


# ---------------------------------------------------------------------------- two real sections


@pytest.mark.slow
def test_a_section_that_could_not_do_its_work_is_reported_failed_with_its_page(tmp_path):
    """A section that ran but says it could not do its work (``ReportSection.error``) keeps its page
    and is reported not ok with that message; a section that raised is reported the same way."""
    from hybobs_opt.errors import ModelError
    from hybobs_opt.report.html import assemble_report
    from hybobs_opt.report.section import ReportSection

    def stopped(out, progress):
        return ReportSection("Simulation", "<p>The run stopped at t = 4.</p>", {"error": "stopped at t = 4"},
                             error="stopped at t = 4")

    def raised(out, progress):
        raise ModelError("x0", "a state", "nothing")

    res = assemble_report(tmp_path, [("fine", _fake_section("Fine", "<p>ok</p>")), ("sim", stopped), ("bad", raised)])
    assert [(s["key"], s["ok"]) for s in res["sections"]] == [("fine", True), ("sim", False), ("bad", False)]
    assert res["sections"][1]["error"] == "stopped at t = 4" and res["sections"][0]["error"] == ""
    assert "The run stopped at t = 4." in (tmp_path / "index.html").read_text()


@pytest.mark.parametrize("key", ["examples", "drift"])
def test_section_reads_as_words_with_units(tmp_path, key):
    """A section built for real (a few seconds each), assembled into the page, passes every check."""
    from hybobs_opt.report.html import _load_builtin_sections, assemble_report
    from hybobs_opt.report.section import _SECTIONS

    _load_builtin_sections()
    assemble_report(tmp_path, [(k, b) for k, b in _SECTIONS if k == key])
    page = (tmp_path / "index.html").read_text()
    assert literal_problems(visible_text(page)) == []
    assert table_problems(page) == []
    assert page.count("<table") >= 1


def test_every_sliding_mode_figure_has_a_heading_in_words():
    """The sliding-mode section heads each figure with a sentence, not its file name."""
    import re
    from pathlib import Path

    from hybobs_opt.report import sliding_section

    source = Path(sliding_section.__file__).read_text(encoding="utf-8")
    saved = set(re.findall(r'"(smo_[a-z0-9_]+\.png)"', source))
    assert len(saved) >= 8
    assert saved == set(sliding_section._HEADINGS)
    assert all(" " in h and not h.startswith("smo") for h in sliding_section._HEADINGS.values())
