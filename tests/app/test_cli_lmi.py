"""``hybobs diagnose`` and ``hybobs synth`` (paper 004's LMIs): the JSON fields, written files, ``--range`` parsing, bad input."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from hybobs_opt import cli
from hybobs_opt.cli._schedule import parse_range
from hybobs_opt.errors import ModelError
from hybobs_opt.studies.paper004_nonmonotonic.presets import get_preset


@pytest.fixture
def lmi_cli():
    assert {"diagnose", "synth"} <= set(cli.COMMANDS)  # registered in the CLI
    return cli


def test_range_parsing_errors():
    p = get_preset("vehicle_tracking")
    names = ("X", "Y", "psi", "delta_f")
    assert parse_range("psi=0:360", p, names) == (0.0, 360.0)
    assert parse_range("psi=0:3.14159265rad", p, names)[1] == pytest.approx(180.0)
    for bad, msg in (("psi=80:0", "LO < HI"), ("psi=0:nan", "finite"), ("psi:0:1", "NAME=LO:HI"),
                     ("X=0:1", "scheduling coordinate"), ("q=0:1", "state of the example"), ("psi=a:b", "numbers")):
        with pytest.raises(ModelError, match=msg):
            parse_range(bad, p, names)


def test_diagnose_json_vehicle_full_circle(lmi_cli, tmp_path, capsys):
    assert lmi_cli.main(["diagnose", "vehicle_tracking", "--range", "psi=0:360", "--out-dir", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["feasible"] is False
    c = out["certificate"]
    assert c["verified"] is True and c["theorem"] == "Theorem 4" and "e_psi" in c["reason"]
    assert (tmp_path / "diagnose_vehicle_tracking.md").exists() and (tmp_path / "diagnose_vehicle_tracking.html").exists()
    assert (tmp_path / "bounds_vehicle_tracking.png").stat().st_size > 1000
    assert out["suggested_regions"] and out["suggested_regions"][0][0] == 0.0
    _assert_page_has_no_python_values(tmp_path / "diagnose_vehicle_tracking.html")
    assert "Dual certificate re-checked in numpy: <b>yes</b>" in (tmp_path / "diagnose_vehicle_tracking.html").read_text()


def _assert_page_has_no_python_values(path):
    from tests.check_report_text import literal_problems, visible_text

    problems = literal_problems(visible_text(path.read_text(encoding="utf-8")))
    # the verdict's first word is upper case on purpose (FEASIBLE / INFEASIBLE / NO GAIN FOUND ...)
    problems = [p for p in problems if not re.search(r"constant name of the code '(IN)?FEASIBLE'", p)]
    assert not problems, problems


def test_diagnose_json_vehicle_0_80_is_feasible(lmi_cli, tmp_path, capsys):
    assert lmi_cli.main(["diagnose", "vehicle_tracking", "--range", "psi=0:80", "--out-dir", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["feasible"] is True and "certificate" not in out and np.array(out["gain"]["L"]).shape == (4, 2)
    page = tmp_path / "diagnose_vehicle_tracking.html"
    _assert_page_has_no_python_values(page)
    L = np.array(out["gain"]["L"])
    for name in ("X", "Y", "psi", "delta_f"):  # the gain as a table, one row per state, 4 significant digits
        assert f"<td>{name}</td>" in page.read_text()
    assert f"{L[0, 0]:.4g}" in page.read_text()


def test_synth_json_writes_the_gains(lmi_cli, tmp_path, capsys):
    path = tmp_path / "gains.json"
    assert lmi_cli.main(["synth", "vehicle_tracking", "--out", str(path), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    written = json.loads(path.read_text())
    for out in (printed, written):
        assert out["tau"] > 0 and len(out["regions"]) == 2
        assert out["regions"][0]["interval"] == pytest.approx([0.0, 80.0])
        for r in out["regions"]:
            assert np.array(r["L"]).shape == (4, 2) and np.array(r["P"]).shape == (4, 4) and r["sigma"] > 0


@pytest.mark.parametrize("argv, msg", [
    (["diagnose", "vehicle_tracking", "--range", "psi=80:0"], "LO < HI"),
    (["diagnose", "vehicle_tracking", "--range", "psi=400:500"], "empty region"),
    (["diagnose", "powertrain3"], "scalar-nonlinear"),
    (["synth", "vehicle_tracking", "--out", "x.json", "--max-rate", "-1"], "--max-rate"),
])
def test_commands_reject_bad_input(lmi_cli, argv, msg, capsys, tmp_path):
    argv = [a if a != "x.json" else str(tmp_path / "x.json") for a in argv]
    assert lmi_cli.main(argv + (["--out-dir", str(tmp_path)] if argv[0] == "diagnose" else [])) == 2
    assert msg in capsys.readouterr().err


ROBOT = "examples/models/flexible_joint_robot.toml"


def test_diagnose_gain_bound_is_the_first_line_and_the_gain_meets_it(lmi_cli, capsys):
    """With --gain-bound the first line says what holds within the bound, and the gain it recommends
    meets the bound: at 5 the LMIs' sufficient form of the bound is infeasible but the exact-bound
    search finds a gain; at 1 neither finds one, and the verdict says so first."""
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)  # the conditions alone: their form of the bound excludes every gain
    assert out["verdict"].startswith("NO GAIN FOUND WITHIN ||L||_2 <= 5") and out["gain_accepted"] is False
    assert out["decay_design"]["exact_bound_search"] is None
    assert any("--exact-bound-search" in s for s in out["next_steps"])
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "5", "--exact-bound-search", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["verdict"].startswith("FEASIBLE: a constant gain with ||L||_2 <= 5 and decay rate")
    assert out["gain_accepted"] is True and out["gain"]["method"] == "exact-bound search"
    assert np.linalg.norm(np.array(out["gain"]["L"]), 2) <= 5 * (1 + 1e-6)
    assert not any(c["feasible"] for c in out["decay_design"]["conditions"])
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "1", "--exact-bound-search"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert "NO GAIN FOUND WITHIN ||L||_2 <= 1" in first and "FEASIBLE" not in first.split(":")[1]
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "1", "--exact-bound-search", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["feasible"] is True and out["gain_accepted"] is False  # a gain exists, none found within the bound
    assert out["verdict"].startswith("NO GAIN FOUND WITHIN ||L||_2 <= 1")
    assert out["decay_design"]["within_bound"] is False
    assert out["decay_design"]["exact_bound_search"]["found"] is False
    assert not any("no switching is needed" in s for s in out["next_steps"])


def test_diagnose_min_decay_is_met_or_refused(lmi_cli, capsys):
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "50", "--json"]) == 0
    rate = json.loads(capsys.readouterr().out)["decay_design"]["sigma_verified"]
    assert rate > 1.0
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "50", "--min-decay", f"{2 * rate:.6g}", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["gain_accepted"] is False and out["verdict"].startswith("DECAY NOT MET")
    assert out["required_decay"] == pytest.approx(2 * rate, rel=1e-5)
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "50", "--min-decay", f"{0.5 * rate:.6g}"]) == 0
    text = capsys.readouterr().out
    assert text.splitlines()[0].split(": ", 1)[1].startswith("FEASIBLE: a constant gain with ||L||_2 <= 50")
    assert "no switching is needed" in text


def test_diagnose_with_a_noise_bound_states_a_certified_error_bound(lmi_cli, capsys, tmp_path):
    assert lmi_cli.main(["diagnose", ROBOT, "--gain-bound", "200", "--noise-bound", "0.01", "--out-dir", str(tmp_path),
                         "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    nd = out["noise_design"]
    assert nd["feasible"] is True and nd["noise"] == [0.01, 0.01] and nd["gain_norm"] <= 200 * (1 + 1e-6)
    assert len(nd["bound"]) == 4 and all(0 < b < np.inf for b in nd["bound"])
    assert nd["alpha"] > 0 and max(nd["lmi_max_eig"]) <= 0
    assert "Under output noise |v| <= [0.01, 0.01]" in out["verdict"]
    assert any(f.endswith(".png") and "noise_tradeoff" in f for f in out["report"]["figures"])
    assert lmi_cli.main(["diagnose", ROBOT, "--noise-bound", "nosuch=1"]) == 2
    assert "--noise-bound" in capsys.readouterr().err


def test_synth_noise_bound_certifies_the_observer_it_synthesised(lmi_cli, capsys, tmp_path):
    """``synth --noise-bound`` on a model file (the robot: one region, so no switch): the synthesised
    gains' bound and gains designed for the noise, each re-checked; the vehicle's switched case, with
    its jumps and dwell time, is tests/unit/lmi/test_switched_noise.py."""
    assert lmi_cli.main(["synth", ROBOT, "--out", str(tmp_path / "g.json"), "--no-verify",
                         "--noise-bound", "0.01", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    given, designed = out["noise_bound"], out["noise_design"]
    assert given["gains"] == "given" and designed["gains"] == "designed"
    for nb in (given, designed):
        assert nb["holds"] is True and nb["noise"] == [0.01, 0.01] and len(nb["bound"]) == 4
        assert all(0 < b < np.inf for b in nb["bound"]) and all(r["verified"] for r in nb["regions"])
        assert nb["jump"] == 1.0 and nb["dwell_needed"] == 0.0 and nb["level"] == 1.0  # no switch
        assert nb["peak_to_peak_gain"] == pytest.approx(np.array(nb["bound"]) / 0.01)
    assert all(np.linalg.norm(np.array(r["L"]), 2) <= out["gain_bound"] * (1 + 1e-6) for r in designed["regions"])
    assert designed["alpha"] >= min(r["sigma"] for r in out["regions"]) * (1 - 1e-3)
    assert max(np.array(designed["bound"]) / np.array(given["bound"])) < 1.0  # designed for it: tighter everywhere
    # the gains file keeps the synthesised gains
    saved = json.loads((tmp_path / "g.json").read_text())
    assert [r["L"] for r in saved["regions"]] == [r["L"] for r in out["regions"]]
