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
