"""``hybobs export SYSTEM -T N --out-dir DIR`` (issue 20): the JSON fields, the warnings of --max-bytes /
--max-ops, and the exported driver replaying a log exactly like ``hybobs observe --data LOG --out``.

The bad inputs are rows of ``test_cli_bad_input.py`` and ``tests/fuzz/test_cli.py``; the C code's
agreement with the Python observer in detail is ``tests/unit/observers/test_c_export.py``.
"""

from __future__ import annotations

import csv
import json
from types import SimpleNamespace

import numpy as np
import pytest

from hybobs_opt import save_model
from hybobs_opt.cli import main
from hybobs_opt.sim import simulate_pwa

from c_replay import build, require_cc
from canonical import deadzone_drive, deadzone_spring


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def _export_of(rec: dict) -> SimpleNamespace:
    from pathlib import Path

    files = {k: Path(v) for k, v in rec["files"].items()}
    return SimpleNamespace(directory=Path(rec["out_dir"]), name=files["header"].stem, source=files["source"],
                           driver=files["driver"])


def test_export_of_a_model_file_replays_a_log_like_hybobs_observe(tmp_path, capsys):
    """A user's model file (the dead-zone spring, not from the papers), T = 4: the exported driver's CSV
    equals ``hybobs observe --out`` on the same log (estimates to 1e-12, modes and flags)."""
    import subprocess

    require_cc()
    system = deadzone_spring()
    model = save_model(system, tmp_path / "deadzone.toml")
    trace = simulate_pwa(system, np.zeros(2), deadzone_drive(800))
    with (tmp_path / "log.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "y", "u"])  # any column order
        for k in range(trace.n_samples):
            w.writerow([repr(0.05 * k), repr(float(trace.y[k, 0])), repr(float(trace.u[k, 0]))])
    code, out, err = run(capsys, "export", model, "-T", "4", "--out-dir", tmp_path / "c", "--json")
    assert code == 0, err
    rec = json.loads(out)
    assert rec["horizon"] == 4 and rec["float32"] is False and rec["warnings"] == []
    assert rec["btilde_test"] == "pairs" and rec["n_btilde_pieces"] > 50 and rec["n_regions"] > 10
    assert rec["table_bytes"] > 0 and rec["max_ops"] == sum(rec["ops"].values()) and rec["max_ops"] > rec["ops"]["window"]
    exe = build(_export_of(rec))
    r = subprocess.run([str(exe), str(tmp_path / "log.csv"), str(tmp_path / "c_out.csv")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    code, out, err = run(capsys, "observe", model, "--data", tmp_path / "log.csv", "--observers", "lookup", "-T", "4",
                         "--out", tmp_path / "py_out.csv", "--json")
    assert code == 0, err
    with (tmp_path / "c_out.csv").open() as fh:
        c_rows = list(csv.reader(fh))
    with (tmp_path / "py_out.csv").open() as fh:
        py_rows = list(csv.reader(fh))
    assert c_rows[0][:-1] == py_rows[0] == ["t", "x1", "x2", "mode", "flag"] and c_rows[0][-1] == "reason"
    assert len(c_rows) == len(py_rows) == trace.n_samples + 1
    c = np.array([[float(v) for v in row[:3]] for row in c_rows[1:]])
    py = np.array([[float(v) for v in row[:3]] for row in py_rows[1:]])
    assert np.max(np.abs(c - py) / np.maximum(1.0, np.abs(py))) <= 1e-12
    assert [row[3:5] for row in c_rows[1:]] == [row[3:5] for row in py_rows[1:]]
    flags = [row[4] for row in py_rows[1:]]
    assert flags.count("observable") > 400 and flags.count("unobservable") > 100
    assert "lps 0 " not in r.stdout  # the B~_T LPs decided some windows


def test_warnings_of_max_bytes_and_max_ops(tmp_path, capsys):
    """Beyond --max-bytes / --max-ops: exit 0, files written, one warning each (stderr, or 'warnings' under --json)."""
    code, out, err = run(capsys, "export", "powertrain3", "-T", "3", "--out-dir", tmp_path / "a", "--max-bytes", "1000",
                         "--max-ops", "100")
    assert code == 0
    lines = [line for line in err.splitlines() if "warning" in line]
    assert len(lines) == 2 and all(line.startswith("hybobs export: warning: ") for line in lines)
    assert "--max-bytes 1,000" in lines[0] and "--max-ops 100" in lines[1]
    assert "tables" in out and "multiply-adds" in out and (tmp_path / "a" / "hybobs_lookup.c").is_file()
    code, out, err = run(capsys, "export", "powertrain3", "--out-dir", tmp_path / "b", "--float32", "--max-bytes",
                         "100000000", "--max-ops", "1000", "--json")
    assert code == 0 and "warning" not in err
    rec = json.loads(out)
    assert rec["float32"] is True and 0 < rec["float32_rounding"] < 0.05 and rec["max_bytes"] == 100000000
    assert len(rec["warnings"]) == 1 and "--max-ops 1,000" in rec["warnings"][0]
    code, out, _ = run(capsys, "export", "powertrain3", "--out", tmp_path / "c", "--json")  # --out: the same option
    double = json.loads(out)
    assert double["table_bytes"] > rec["table_bytes"] and double["max_ops"] == rec["max_ops"]
    assert "typedef float" in (tmp_path / "b" / "hybobs_lookup.h").read_text()
    assert "typedef double" in (tmp_path / "c" / "hybobs_lookup.h").read_text()


def test_tables_beyond_the_limit_are_refused_with_one_line(tmp_path, capsys, monkeypatch):
    import hybobs_opt.observers.c_export as ce

    monkeypatch.setattr(ce, "MAX_EXPORT_TABLE_BYTES", 10_000)
    code, out, err = run(capsys, "export", "powertrain3", "--out-dir", tmp_path / "c", "--no-cache")
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith("hybobs export: error: --horizon: expected tables of at most 10,000 bytes")
    assert "MAX_EXPORT_TABLE_BYTES" in lines[0] and "T = 3" in lines[0]
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("argv", [["export", "--help"], ["--help"]])
def test_help_lists_export(capsys, argv):
    code, out, _ = run(capsys, *argv)
    assert code == 0 and "export" in out
    if argv[0] == "export":
        for option in ("--out-dir", "--float32", "--max-bytes", "--max-ops", "--horizon", "--param", "--no-cache"):
            assert option in out
