"""Text mode of the ``hybobs`` commands: readable summaries (4 significant digits, units, no Python
reprs) and a first line on a terminal before the heavy imports."""

from __future__ import annotations

import re

import pytest

from hybobs_opt.cli import main
from hybobs_opt.cli._text import summary_lines

ROTATION = "examples/models/bemporad_morari_rotation.toml"
LOG = "tests/app/cli_json_golden/inputs/rotation_sine.csv"

#: A Python repr of a container, or a float printed with more than 4 significant digits.
REPR = re.compile(r"[\[{]'|\{'|dict of|list of|\(use --json\)")
NUMBER = re.compile(r"(?<![\w.])\d+\.\d+(?:e[-+]?\d+)?")


def long_floats(text: str) -> list[str]:
    """Decimal numbers in ``text`` with more than 4 significant digits."""
    return [m for m in NUMBER.findall(text) if len(m.split("e")[0].replace(".", "").lstrip("0")) > 4]


def test_summary_lines_round_and_give_units():
    summary = {"horizon": 3, "run_seconds": 0.016110408999963965, "flag_counts": {"observable": 0, "fallback": 2},
               "ok": True, "missing": None, "M0_per_state": [0.5541152646847144, 5.0928107745937305],
               "delays": {"q1": 0.04146867484339065}, "samples": list(range(20)),
               "changes": [{"t": 2.1119820591132474, "to": "q2"}], "nested": {"decay": 10.00019101125384, "cond": [1.5, 2]}}
    assert summary_lines(summary, {"q1": "s"}) == [
        "horizon: 3",
        "run_seconds: 0.01611 s",
        "flag_counts: observable 0, fallback 2",
        "ok: yes",
        "missing: n/a",
        "M0_per_state: 0.5541, 5.093",
        "delays: q1 0.04147 s",
        "samples: 20 values from 0 to 19",
        "changes: 1 entry",
        "  t 2.112 s, to q2",
        "nested:",
        "  decay: 10 1/s",
        "  cond: 1.5, 2",
    ]


@pytest.mark.parametrize("argv", [
    ["observe", ROTATION, "--data", LOG, "-T", "3", "--observers", "lookup", "--no-cache"],
    ["observe", "driveline"],
    ["model", "check", "powertrain3"],
    ["simulate", "powertrain3", "--t-final", "0.05"],
    ["regions", "powertrain3", "-T", "3", "--executor", "serial", "--cut", "omega_l=25", "--resolution", "5x4"],
    ["bench", "powertrain3", "--observers", "lookup", "--steps", "50"],
])
def test_text_mode_has_no_reprs_and_no_long_floats(capsys, argv):
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert text.strip()
    assert not REPR.search(text), REPR.search(text)
    assert not long_floats(text), long_floats(text)


def test_first_line_on_a_terminal_comes_before_the_work(capsys, monkeypatch):
    """On a terminal the first stderr line names the command before the system is loaded (the
    seconds of importing the solvers are no longer silent); off a terminal (pipes, logs, tests)
    the output is what it was."""
    import hybobs_opt.cli.model as model_cli

    events = []
    real = model_cli.load_system
    monkeypatch.setattr(model_cli, "load_system", lambda args: (events.append("load"), real(args))[1])
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    import sys

    class Tty:
        def __init__(self, stream):
            self.stream = stream

        def isatty(self):
            return True

        def write(self, text):
            events.append(("stderr", text))
            return self.stream.write(text)

        def flush(self):
            self.stream.flush()

    monkeypatch.setattr(sys, "stderr", Tty(sys.stderr))
    assert main(["model", "check", "powertrain3"]) == 0
    first = next(e for e in events if e == "load" or e[1].strip())
    assert first == ("stderr", "hybobs model: loading the model (numpy, scipy) ..."), events[:3]
    monkeypatch.undo()
    capsys.readouterr()
    assert main(["model", "check", "powertrain3"]) == 0
    assert capsys.readouterr().err == ""


#: A command line per command that loads a system, with the options whose checks could import a
#: heavy module (a figure path: matplotlib) before the first line.
FIRST_LINE_ARGV = [
    ["simulate", "powertrain3", "--plot", "x.png"],
    ["observe", "powertrain3", "--plot", "x.png"],
    ["regions", "powertrain3", "--plot", "x.png"],
    ["bench", "powertrain3", "--plot", "x.png"],
    ["export", "powertrain3", "--out-dir", "d"],
    ["diagnose", "vehicle_tracking"],
    ["synth", "vehicle_tracking", "--out", "g.json"],
    ["model", "check", "powertrain3"],
    ["report", "--out-dir", "d"],
]

_PROBE = """
import importlib, json, sys
from hybobs_opt.cli import COMMANDS, build_parser
HEAVY = ("numpy", "scipy", "cvxpy", "casadi", "matplotlib", "numba")
seen = []
class Stop(Exception):
    pass
def announce(args, what):
    seen.append([m for m in HEAVY if m in sys.modules])
    raise Stop
args = build_parser().parse_args(ARGV)
importlib.import_module("hybobs_opt.cli." + COMMANDS[args.command]).announce = announce
try:
    args.func(args)
except Stop:
    pass
print(json.dumps(seen))
"""


@pytest.mark.parametrize("argv", FIRST_LINE_ARGV, ids=lambda a: a[0])
def test_the_first_line_comes_before_any_heavy_import(argv):
    """Each command announces itself before numpy, scipy, cvxpy, CasADi or matplotlib is imported
    (a fresh interpreter; the first line is then within the interpreter's start-up and the parser's)."""
    import json
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _PROBE.replace("ARGV", repr(argv))], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == [[]], (argv, done.stdout)
