"""Compile an exported lookup observer (``hybobs_opt.observers.c_export``) with the system's C compiler
and replay samples through its generated driver; shared by the unit and CLI tests of the export.

The expected answers of those tests come from the Python observer (``LookupObserver.run``), never
from the generator: this module only builds the C code and reads what the driver wrote.
"""

from __future__ import annotations

import csv
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

#: The compiler and flags of issue 20: strict C99, every warning an error.
CC = shutil.which("cc")
CFLAGS = ("-std=c99", "-Wall", "-Werror", "-O2")

#: Flag codes of the generated header (the vocabulary of hybobs_opt.contract).
FLAGS = ("observable", "unobservable", "fallback", "warming_up")


def require_cc() -> str:
    """The path of ``cc``, or skip the test (the exported code cannot be compiled without one)."""
    if CC is None:
        pytest.skip("no C compiler 'cc' on PATH: the exported C99 code cannot be compiled and replayed")
    return CC


def build(export) -> Path:
    """``cc -std=c99 -Wall -Werror -O2 NAME.c NAME_driver.c -lm``: the driver executable (fails the test on any warning)."""
    cc = require_cc()
    exe = export.directory / f"{export.name}_driver"
    r = subprocess.run([cc, *CFLAGS, str(export.source), str(export.driver), "-lm", "-o", str(exe)],
                       capture_output=True, text=True)
    assert r.returncode == 0 and not r.stderr.strip(), f"cc failed ({r.returncode}):\n{r.stderr[:4000]}"
    return exe


def write_log(path: Path, system, U: np.ndarray, Y: np.ndarray) -> Path:
    """A CSV log ``t, inputs..., outputs...`` with every number as Python's ``repr`` (``nan``, ``inf`` included)."""
    with path.open("w") as fh:
        fh.write(",".join(["t", *system.input_names, *system.output_names]) + "\n")
        for k in range(U.shape[0]):
            fh.write(",".join(repr(float(v)) for v in (k, *U[k], *Y[k])) + "\n")
    return path


@dataclass
class Replay:
    """What the driver wrote: per sample the estimate, mode, flag and reason code; its LP counters."""

    x: np.ndarray
    mode: np.ndarray
    flags: np.ndarray
    reasons: np.ndarray
    stats: dict
    times_ns: np.ndarray | None = None


def replay(exe: Path, system, U: np.ndarray, Y: np.ndarray, work: Path, repeats: int | None = None) -> Replay:
    """Run the driver on ``U, Y`` (written to ``work/log.csv``) and read ``work/out.csv``."""
    log = write_log(work / "log.csv", system, U, Y)
    out = work / "out.csv"
    argv = [str(exe), str(log), str(out)] + ([str(work / "times.csv"), str(repeats)] if repeats else [])
    r = subprocess.run(argv, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    stats = {}
    for line in r.stdout.splitlines():
        words = line.split()
        stats.update({words[i]: int(words[i + 1]) for i in range(0, len(words) - 1, 2)})
    with out.open() as fh:
        rows = list(csv.reader(fh))
    n = system.n
    assert rows[0] == ["t", *system.state_names, "mode", "flag", "reason"]
    body = rows[1:]
    assert len(body) == U.shape[0]
    times = np.loadtxt(work / "times.csv", delimiter=",", ndmin=2) if repeats else None
    return Replay(np.array([[float(v) for v in row[1 : 1 + n]] for row in body]),
                  np.array([int(row[1 + n]) for row in body]), np.array([row[2 + n] for row in body]),
                  np.array([int(row[3 + n]) for row in body]), stats, times)


def sizes(exe: Path) -> dict[str, int]:
    """``driver --sizes``: the bytes of the tables and of the state struct as the compiler counts them."""
    r = subprocess.run([str(exe), "--sizes"], capture_output=True, text=True, check=True)
    return {k: int(v) for k, v in (line.split() for line in r.stdout.splitlines())}


def relative_error(x_c: np.ndarray, x_py: np.ndarray) -> np.ndarray:
    """``|x_c - x_py| / max(1, |x_py|)`` per sample and state (the suite's measure of exact reconstruction)."""
    return np.abs(x_c - x_py) / np.maximum(1.0, np.abs(x_py))


def code_only(text: str) -> str:
    """C source without its comments and string / character literals (translation phase 3, for
    text without line splices or trigraphs)."""
    out, i, n = [], 0, len(text)
    while i < n:
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            assert j >= 0, "unterminated comment"
            i = j + 2
            out.append(" ")
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text[i] in "\"'":
            q, j = text[i], i + 1
            while text[j] != q:
                j += 2 if text[j] == "\\" else 1
            i = j + 1
            out.append('""')
        else:
            out.append(text[i])
            i += 1
    return "".join(out)
