"""``hybobs -v`` / ``-vv``: log lines on stderr, never on stdout (``--json`` stays one JSON document)."""

from __future__ import annotations

import json
import logging
from pathlib import Path

from hybobs_opt.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
ROT = str(ROOT / "examples" / "models" / "bemporad_morari_rotation.toml")
ROT_LOG = str(ROOT / "tests" / "app" / "cli_json_golden" / "inputs" / "rotation_sine.csv")


def _run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_verbose_is_a_counted_top_level_flag():
    parser = build_parser()
    assert parser.parse_args(["examples"]).verbose == 0
    assert parser.parse_args(["-v", "examples"]).verbose == 1
    assert parser.parse_args(["-vv", "examples"]).verbose == 2
    assert parser.parse_args(["--verbose", "--verbose", "examples"]).verbose == 2


def test_v_regions_json_on_stdout_log_on_stderr(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("HYBOBS_CACHE_DIR", str(tmp_path))
    code, out, err = _run(capsys, "-v", "regions", ROT, "-T", "3", "--executor", "serial", "--no-cache", "--json")
    assert code == 0
    data = json.loads(out)  # nothing else on stdout
    assert data["horizon"] == 3
    lines = err.splitlines()
    assert any(ln.startswith("hybobs INFO hybobs_opt.regions.observability: Algorithm 3.1 of paper 002 at T = 3: "
                             f"mode enumeration gave {data['n_regions']} regions") for ln in lines), err
    assert any(f"with {data['n_lps_pairs']} LPs" in ln for ln in lines), err
    assert not any(" DEBUG " in ln for ln in lines)
    # the handler is gone after the command
    assert not [h for h in logging.getLogger("hybobs_opt").handlers if not isinstance(h, logging.NullHandler)]


def test_without_v_nothing_is_logged(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("HYBOBS_CACHE_DIR", str(tmp_path))
    code, out, err = _run(capsys, "regions", ROT, "-T", "3", "--executor", "serial", "--no-cache", "--json")
    assert code == 0 and json.loads(out)["horizon"] == 3
    assert "hybobs INFO" not in err


def test_vv_observe_logs_every_window_at_debug(capsys):
    code, out, err = _run(capsys, "-vv", "observe", ROT, "--data", ROT_LOG, "-T", "3", "--observer", "miqp", "--json")
    assert code == 0
    data = json.loads(out)
    windows = [ln for ln in err.splitlines() if ln.startswith("hybobs DEBUG hybobs_opt.mhe.observer: MHE window:")]
    assert len(windows) == data["n_samples"] - 2  # T - 1 warming-up samples have no window
    assert any(ln.startswith("hybobs INFO hybobs_opt.mhe.observer: MHE run (T = 3") for ln in err.splitlines())


def test_v_with_an_error_under_json_keeps_one_json_object(capsys):
    code, out, _ = _run(capsys, "-v", "regions", ROT, "-T", "0", "--json")
    assert code == 2
    assert "error" in json.loads(out)
