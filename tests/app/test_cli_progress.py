"""Progress on every long command (issue 17): under a pseudo-terminal each one draws tqdm bars that
name their phase and count it in units; under ``--json`` (and in pipes, as in the rest of the
suite) nothing is drawn."""

from __future__ import annotations

import os
import pty
import re
import select
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def run_in_pty(args: list[str], tmp_path, env_extra: dict | None = None, timeout: float = 300.0) -> tuple[int, str, str]:
    """Run ``hybobs ARGS`` with stderr on a pseudo-terminal (stdout a pipe); ``(code, stdout, tty text)``."""
    master, slave = pty.openpty()
    env = {**os.environ, "HYBOBS_CACHE_DIR": str(tmp_path / "cache"), "COLUMNS": "160", **(env_extra or {})}
    proc = subprocess.Popen([sys.executable, "-m", "hybobs_opt.cli", *args], stdout=subprocess.PIPE, stderr=slave,
                            stdin=subprocess.DEVNULL, env=env, cwd=tmp_path)
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], timeout)
        if not ready:
            proc.kill()
            raise AssertionError(f"hybobs {' '.join(args)}: no output for {timeout} s")
        try:
            data = os.read(master, 65536)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    out = proc.stdout.read().decode()
    code = proc.wait(timeout)
    return code, out, _ANSI.sub("", b"".join(chunks).decode(errors="replace"))


def bars(tty: str) -> list[str]:
    """The bar lines tqdm drew (``desc: pct%|...| done/total [elapsed<left, rate unit/s]``, or
    ``desc: done unit [elapsed, rate unit/s]`` when the total is not known)."""
    return [part.strip() for part in re.split(r"[\r\n]", tty) if "[" in part and re.search(r"/s|s/", part)]


#: Long commands, with (phase, unit) pairs their bars must show.
LONG_COMMANDS = {
    "regions": (["regions", "powertrain5", "-T", "5", "--no-cache"],
                [("mode enumeration", "prefix"), ("pair tests", "pair")]),
    "regions cut": (["regions", "powertrain3", "-T", "3", "--cut", "omega_m=0", "--resolution", "12x10", "--no-cache"],
                    [("cut", "point")]),
    "observe": (["observe", "powertrain3", "--no-cache"],
                [("Algorithm 3.1: pair tests", "pair"), ("exact labels", "state"), ("lookup tables", "piece"),
                 ("lookup (step by step)", "step")]),
    "bench": (["bench", "powertrain3", "--observers", "lookup,miqp", "--mhe-steps", "40", "--no-cache"],
              [("lookup (batch)", "step"), ("miqp", "step")]),
    "synth": (["synth", "magnetic_piston", "--out", "gains.json"], [("LMI solves", "solve")]),
    "diagnose": (["diagnose", "vehicle_tracking"], [("LMI solves", "solve")]),
    "report": (["report", "--section", "drift", "--out-dir", "rep"], [("report", "section")]),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(LONG_COMMANDS))
def test_long_command_shows_bars_with_units(name, tmp_path):
    args, expected = LONG_COMMANDS[name]
    code, _, tty = run_in_pty(args, tmp_path)
    assert code == 0, tty[-2000:]
    drawn = bars(tty)
    for phase, unit in expected:
        hits = [b for b in drawn if b.startswith(phase) and re.search(rf"{re.escape(unit)}s?/s|s/{re.escape(unit)}", b)]
        assert hits, f"{name}: no bar of phase {phase!r} counting {unit!r}; bars drawn: {sorted(set(drawn))[:12]}"


@pytest.mark.parametrize("name", ["regions", "observe", "bench"])
def test_json_draws_nothing(name, tmp_path):
    args, _ = LONG_COMMANDS[name]
    code, out, tty = run_in_pty([*args, "--json"], tmp_path)
    assert code == 0, out[-2000:]
    assert tty.strip() == "", f"--json wrote to the terminal: {tty[:500]!r}"
    import json

    json.loads(out)


@pytest.mark.slow
def test_second_observe_starts_from_the_cache_and_says_so(tmp_path):
    args = ["observe", "powertrain3"]
    code, _, first = run_in_pty(args, tmp_path)
    assert code == 0, first[-2000:]
    assert "computed and stored in the cache" in first and "loaded from the cache" not in first
    code, _, second = run_in_pty(args, tmp_path)
    assert code == 0, second[-2000:]
    for what in ("observability analysis of", "exact labels of", "lookup tables of B~_T"):
        assert re.search(rf"{re.escape(what)}[^\n]*loaded from the cache", second), second[-2000:]
    # nothing of Algorithm 3.1 is computed again: no pair-test bar on the second run
    assert not [b for b in bars(second) if "pair tests" in b]


@pytest.mark.parametrize("args, first", [
    (["model", "check", "powertrain3"], "hybobs model: loading the model (numpy, scipy) ..."),
    (["regions", "powertrain3", "-T", "3", "--executor", "serial"], "hybobs regions: loading the LP solvers (numpy, scipy, HiGHS) ..."),
])
def test_text_mode_on_a_terminal_starts_with_what_it_loads(args, first, tmp_path):
    """The terminal's first line names the command before its imports; stdout is unchanged."""
    code, out, tty = run_in_pty(args, tmp_path)
    assert code == 0, tty[-2000:]
    assert tty.splitlines()[0].strip() == first, tty[:300]
    assert "loading" not in out
