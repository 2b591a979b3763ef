"""The 10-line example of the README is the one of the documentation's front page, and it runs.

README.md ("A 10-line example") and docs/index.rst ("A first observer") show the same code and
the same printed lines; this test extracts both code blocks, checks that they are identical,
runs the code and compares what it prints with the output both pages show: each observer's flag
counts exactly, the errors as orders of magnitude (the last digits of a 1e-11 error are rounding).
"""

from __future__ import annotations

import contextlib
import io
import re
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _readme_blocks() -> tuple[str, str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## A 10-line example", 1)[1].split("\n## ", 1)[0]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    output = re.search(r"```text\n(.*?)```", section, re.S).group(1)
    return code, output


def _rst_block(text: str, directive: str) -> str:
    """The body of the first ``.. code-block:: {directive}`` of ``text``, dedented."""
    body = text.split(f".. code-block:: {directive}\n", 1)[1].split("\n", 1)[1]
    lines = []
    for line in body.splitlines():
        if line and not line.startswith("   "):
            break
        lines.append(line)
    return textwrap.dedent("\n".join(lines)).strip("\n") + "\n"


def _index_blocks() -> tuple[str, str]:
    text = (ROOT / "docs" / "index.rst").read_text(encoding="utf-8")
    section = text.split("A first observer\n----------------", 1)[1]
    return _rst_block(section, "python"), _rst_block(section, "text")


def _parse(lines: str) -> list[tuple[str, int, int, int, float]]:
    rows = []
    for line in lines.strip().splitlines():
        m = re.fullmatch(r"(\S+): (\d+) observable, (\d+) unobservable, (\d+) warming up; "
                         r"largest error when observable (\S+)", line.strip())
        assert m, line
        rows.append((m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(4)), float(m.group(5))))
    return rows


def test_readme_and_front_page_show_the_same_example():
    readme_code, readme_output = _readme_blocks()
    index_code, index_output = _index_blocks()
    assert readme_code == index_code
    assert readme_output.strip() == index_output.strip()
    assert len(readme_code.strip().splitlines()) <= 12


def test_the_example_prints_what_the_pages_show():
    code, output = _readme_blocks()
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "README.md", "exec"), {"__name__": "readme_example"})
    shown, got = _parse(output), _parse(printed.getvalue())
    assert [row[:4] for row in got] == [row[:4] for row in shown]
    assert [row[0] for row in got] == ["lookup", "mhe-miqp-2"]
    for row_shown, row_got in zip(shown, got):
        assert row_got[1] > 0 and row_got[2] > 0  # the run crosses the backlash gap
        assert row_got[4] < 1e-8 and row_shown[4] < 1e-8


def test_the_own_system_page_example_prints_what_it_shows(tmp_path, monkeypatch):
    """docs/own_system.rst, "From Python": measuring x1 the observers claim the samples after the
    first window, measuring x2 (mirror symmetry) the lookup observer claims none."""
    text = (ROOT / "docs" / "own_system.rst").read_text(encoding="utf-8")
    section = text.split("From Python\n-----------", 1)[1]
    code, output = _rst_block(section, "python"), _rst_block(section, "text")
    code = code.replace('"examples/builders/', f'"{ROOT.as_posix()}/examples/builders/')
    monkeypatch.chdir(tmp_path)  # the example writes log.csv
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "own_system.rst", "exec"), {"__name__": "own_system_example"})
    assert printed.getvalue().split() == output.split()
    assert "y = (1.0, 0.0): lookup 46 of 48" in output and "y = (0.0, 1.0): lookup  0 of 48" in output
