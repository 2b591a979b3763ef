"""Model files are parsed within limits checked before the work: a YAML alias bomb is refused as the
parser meets its aliases, an oversized file before it is read.  Oracle: the exit status, the one
line of the message and the wall time of the command."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.systems import load_model

REPO = Path(__file__).resolve().parents[2]

BOMB = "\n".join([
    'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]',
    *(f"{x}: &{x} [{', '.join([f'*{p}'] * 9)}]" for p, x in zip("abcdefgh", "bcdefghi")),
]) + "\n"


def test_the_yaml_alias_bomb_is_refused_in_seconds_with_one_line(tmp_path):
    path = tmp_path / "bomb.yaml"
    path.write_text(BOMB)
    assert len(BOMB) < 900  # the campaign's file: 820 bytes, 9 levels
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "hybobs_opt.cli", "model", "check", str(path)], capture_output=True,
                       text=True, timeout=60, cwd=REPO)
    assert time.perf_counter() - t0 < 10.0
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "aliases" in r.stderr


def test_an_oversized_model_file_is_refused_before_it_is_read(tmp_path, monkeypatch):
    import hybobs_opt.limits as limits

    path = tmp_path / "big.json"
    path.write_text("{" + " " * 5000 + "}")
    monkeypatch.setattr(limits, "MAX_MODEL_FILE_BYTES", 4096)
    with pytest.raises(ModelError, match="at most 4,096 bytes"):
        load_model(path)


def test_a_yaml_model_with_a_few_aliases_still_loads(tmp_path):
    src = (REPO / "examples/models/flexible_joint_robot.yaml").read_text()
    assert load_model(REPO / "examples/models/flexible_joint_robot.yaml").n == 4
    with_alias = src.replace("format:", "_bounds: &u [-1.0, 1.0]\nformat:", 1) if "format:" in src else src
    path = tmp_path / "robot.yaml"
    path.write_text(with_alias)
    try:
        load_model(path)
    except ModelError as exc:  # an unknown top-level key may be refused, never for its alias
        assert "alias" not in str(exc)


# ------------------------------------------------------------------ identifiers and numbers

def _spring_model(tmp_path: Path, edit) -> Path:
    import json

    from canonical import deadzone_spring
    from hybobs_opt.systems import save_model

    path = tmp_path / "m.json"
    save_model(deadzone_spring(), path)
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, ensure_ascii=False))
    return path


def test_names_that_normalise_to_the_same_identifier_are_refused(tmp_path):
    """``x`` and ``𝐱`` (MATHEMATICAL BOLD SMALL X) are one name to Python's parser, which reads the
    expressions: two states that differ only so would have a guard on one built on the other."""
    def two_xs(d):
        d["states"] = ["x", "\U0001d431"]

    with pytest.raises(ModelError, match="NFKC"):
        load_model(_spring_model(tmp_path, two_xs))

    def bold_only(d):
        d["states"] = ["\U0001d431", "x2"]

    assert load_model(_spring_model(tmp_path, bold_only)).state_names[0] == "x"  # normalised, as in expressions


def test_names_that_normalise_to_one_identifier_are_refused_in_python_built_systems():
    """The same rule for a system built in Python: its names reach model files (``save_model``),
    log headers and ``--x0 NAME=VALUE``, where ``x`` and ``𝐱`` would be one name."""
    import numpy as np

    from hybobs_opt.systems import Polytope, PWAMode, PWASystem

    mode = PWAMode(np.eye(2), np.zeros((2, 1)), np.zeros(2), np.array([[1.0, 0.0]]),
                   Polytope(np.array([[0.0, 0.0, 1.0]]), np.array([10.0])))
    box = (Polytope.from_box([-1, -1], [1, 1]), Polytope.from_box([-1], [1]))
    with pytest.raises(ModelError, match="state_names.*NFKC"):
        PWASystem((mode,), *box, state_names=("x", "\U0001d431"))
    with pytest.raises(ModelError, match="input_names.*NFKC"):
        PWASystem((mode,), *box, state_names=("x", "v"), input_names=("\uff58",))  # FULLWIDTH x
    assert PWASystem((mode,), *box, state_names=("\U0001d431", "v")).state_names[0] == "\U0001d431"  # kept as given


@pytest.mark.parametrize("number", ["8_0", "0x10", "1" + "0" * 400, "1e400", "\u0663", "\uff13"])
def test_one_number_grammar_in_expressions(number):
    import casadi as ca

    from hybobs_opt.systems.expressions import parse_expression

    with pytest.raises(ModelError, match="f"):
        parse_expression(f"{number} * x", {"x": ca.SX.sym("x")}, "f")


def test_a_six_thousand_term_inequality_is_one_line_not_a_traceback(tmp_path):
    def long_guard(d):
        d["modes"][0]["guard"] = {"inequalities": [" + ".join(["x1"] * 6600) + " <= 1"]}

    r = subprocess.run([sys.executable, "-m", "hybobs_opt.cli", "model", "check", str(_spring_model(tmp_path, long_guard))],
                       capture_output=True, text=True, timeout=120, cwd=REPO)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("cell", ["8_0", "\u0663", "0x10", "1e400", "inf", "nan", "1,5"])
def test_one_number_grammar_in_csv_logs(tmp_path, cell):
    from canonical import deadzone_spring
    from hybobs_opt.sim.log import read_log

    path = tmp_path / "log.csv"
    path.write_text(f"t,u,y\n0,0.1,0.2\n\n\n1,\"{cell}\",0.3\n")
    with pytest.raises(ModelError, match="line 5 column"):  # blank lines counted
        read_log(path, deadzone_spring())


def test_a_byte_order_mark_is_not_part_of_a_column_name(tmp_path):
    from canonical import deadzone_spring
    from hybobs_opt.sim.log import read_log

    path = tmp_path / "log.csv"
    path.write_bytes("\ufefft,u,y\n0,0.1,0.2\n1,0.2,0.3\n".encode("utf-8"))
    assert read_log(path, deadzone_spring()).n_samples == 2
