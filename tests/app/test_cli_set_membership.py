"""``hybobs observe SYSTEM --data LOG --observer set_membership --noise-bound NAME=VALUE``: the
certified radii reach the CSV and the JSON, and the true states of the log lie within them."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from hybobs_opt.cli import main
from hybobs_opt.sim import simulate_pwa
from hybobs_opt.systems import load_model
from hybobs_opt.tolerances import SET_MEMBERSHIP_BOX_RTOL

MODEL = Path(__file__).resolve().parents[2] / "examples/models/bemporad_morari_rotation.toml"


def _log(path: Path, bound: float, N: int = 40) -> np.ndarray:
    system = load_model(MODEL)
    rng = np.random.default_rng(11)
    U = rng.uniform(-1, 1, size=(N, 1))
    tr = simulate_pwa(system, np.array([3.0, -2.0]), U)
    Y = tr.y + rng.uniform(-bound, bound, size=tr.y.shape)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "u", "y", "x1", "x2"])
        for k in range(N):
            w.writerow([k, U[k, 0], Y[k, 0], tr.x[k, 0], tr.x[k, 1]])
    return tr.x


def test_radii_reach_the_csv_and_json_and_hold_the_true_states(tmp_path, capsys):
    X = _log(tmp_path / "log.csv", 0.02)
    out = tmp_path / "est.csv"
    code = main(["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "--observers", "set_membership",
                 "--noise-bound", "y=0.02", "-T", "3", "--out", str(out), "--json"])
    assert code == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["n_outside_radius"] == 0 and len(rec["radius_max"]) == 2
    # y = x2: the radius of x2 is the noise bound, plus the box's pad (the MILPs' feasibility tolerance)
    assert abs(rec["radius_max"][1] - 0.02 - SET_MEMBERSHIP_BOX_RTOL * 10.0) <= 1e-9
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0]) == ["t", "x1", "x2", "mode", "flag", "radius_x1", "radius_x2"]
    checked = 0
    for k, row in enumerate(rows):
        if row["flag"] == "warming_up":
            assert row["radius_x1"] == ""
            continue
        est = np.array([float(row["x1"]), float(row["x2"])])
        radius = np.array([float(row["radius_x1"]), float(row["radius_x2"])])
        assert np.all(np.abs(est - X[k]) <= radius + 1e-9)
        # the mirror image fits as well as the truth: the radius of x1 is at least |x1|
        assert radius[0] >= abs(X[k, 0]) - 0.05
        assert (row["flag"] == "observable") == bool(np.all(radius <= [0.5, 0.5]))
        checked += 1
    assert checked == len(rows) - 2


def test_noise_bound_is_required_by_set_membership_and_refused_elsewhere(tmp_path, capsys):
    _log(tmp_path / "log.csv", 0.0, N=6)
    base = ["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3"]
    assert main(base + ["--observers", "set_membership"]) == 2
    assert "--noise-bound" in capsys.readouterr().err
    assert main(base + ["--observers", "miqp", "--noise-bound", "z=0.1"]) == 2
    assert "'z'" in capsys.readouterr().err
    assert main(base + ["--observers", "set_membership", "--noise-bound", "z=0.1"]) == 2
    assert "'z'" in capsys.readouterr().err
    assert main(base + ["--observers", "set_membership", "--noise-bound", "0.1", "--fit-tolerance", "0.1"]) == 2
    assert "--noise-bound" in capsys.readouterr().err
    assert main(base + ["--observers", "set_membership", "--noise-bound", "0"]) == 0


def test_bench_compares_radius_and_error_on_a_log(tmp_path, capsys):
    _log(tmp_path / "log.csv", 0.01, N=30)
    code = main(["bench", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3", "--observers",
                 "miqp,set_membership", "--noise-bound", "0.01", "--json"])
    assert code == 0
    rec = json.loads(capsys.readouterr().out)["observers"]
    sm = rec["set_membership"]
    assert sm["n_outside_radius"] == 0 and "radius_max" in sm
    assert rec["miqp"]["n_outside_radius"] == 0 and "radius_max" in rec["miqp"]  # the MHE's radii, same bound
    assert sm["solver"] == "highs (MILPs)"
    assert main(["bench", str(MODEL), "--observers", "set_membership", "--noise-bound", "0.01"]) == 2
    assert "--data" in capsys.readouterr().err
    assert main(["bench", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3", "--observers", "miqp",
                 "--json"]) == 0
    assert "radius_max" not in json.loads(capsys.readouterr().out)["observers"]["miqp"]


def test_the_lookup_observer_with_a_noise_bound_reports_radii_that_hold_the_true_states(tmp_path, capsys):
    """``--observer lookup --noise-bound``: the lookup table's bounded-noise path.  y = x2 leaves the
    sign of x1 free (every state is unobservable): no step may be flagged unless the mirror image
    lies within the tolerance, and the true state is inside every radius."""
    X = _log(tmp_path / "log.csv", 0.02)
    out = tmp_path / "est.csv"
    code = main(["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "--observers", "lookup",
                 "--noise-bound", "y=0.02", "-T", "3", "--out", str(out), "--json"])
    assert code == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["n_outside_radius"] == 0 and rec["solver"] == "none (lookup table, bounded noise)"
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0]) == ["t", "x1", "x2", "mode", "flag", "radius_x1", "radius_x2"]
    checked = 0
    for k, row in enumerate(rows):
        if row["flag"] == "warming_up":
            continue
        est = np.array([float(row["x1"]), float(row["x2"])])
        radius = np.array([float(row["radius_x1"]), float(row["radius_x2"])])
        assert np.all(np.abs(est - X[k]) <= radius + 1e-9)
        assert radius[0] >= abs(X[k, 0]) - 0.05  # the mirror image is inside the box too
        assert (row["flag"] == "observable") == bool(np.all(radius <= [0.5, 0.5]))
        checked += 1
    assert checked == len(rows) - 2
    # the table's box holds the exact one of the set-membership MILPs (another formulation and solver)
    exact = tmp_path / "exact.csv"
    assert main(["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "--observers", "set_membership",
                 "--noise-bound", "y=0.02", "-T", "3", "--out", str(exact)]) == 0
    capsys.readouterr()
    for row, ref in zip(rows, csv.DictReader(exact.open())):
        if row["flag"] == "warming_up":
            continue
        for s in ("x1", "x2"):
            lo, hi = float(row[s]) - float(row["radius_" + s]), float(row[s]) + float(row["radius_" + s])
            lo_x, hi_x = float(ref[s]) - float(ref["radius_" + s]), float(ref[s]) + float(ref["radius_" + s])
            assert lo <= lo_x + 1e-6 and hi >= hi_x - 1e-6, (row, ref)
    # without a bound the lookup observer is the exact one (no radius)
    base = ["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3"]
    assert main(base + ["--observers", "lookup", "--json"]) == 0
    assert "radius_max" not in json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("observer", ["miqp", "milp"])
def test_a_moving_horizon_observer_with_a_noise_bound_reports_radii_around_its_estimate(tmp_path, capsys, observer):
    """``--observer miqp|milp --noise-bound``: the window optimum with the radius of the consistent
    box around it.  The interval ``estimate +- radius`` holds the set-membership observer's exact
    box and the true state; y = x2 leaves the sign of x1 free, so a flag needs |x1| within the
    tolerance."""
    X = _log(tmp_path / "log.csv", 0.02)
    out, exact = tmp_path / "est.csv", tmp_path / "exact.csv"
    base = ["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3", "--noise-bound", "y=0.02"]
    assert main(base + ["--observers", observer, "--out", str(out), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["n_outside_radius"] == 0 and len(rec["radius_max"]) == 2
    assert main(base + ["--observers", "set_membership", "--out", str(exact)]) == 0
    capsys.readouterr()
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0]) == ["t", "x1", "x2", "mode", "flag", "radius_x1", "radius_x2"]
    checked = 0
    for k, (row, ref) in enumerate(zip(rows, csv.DictReader(exact.open()))):
        if row["flag"] in ("warming_up", "fallback"):
            continue
        est = np.array([float(row["x1"]), float(row["x2"])])
        radius = np.array([float(row["radius_x1"]), float(row["radius_x2"])])
        assert np.all(np.abs(est - X[k]) <= radius + 1e-9)
        for j, s in enumerate(("x1", "x2")):
            lo_x, hi_x = float(ref[s]) - float(ref["radius_" + s]), float(ref[s]) + float(ref["radius_" + s])
            assert est[j] - radius[j] <= lo_x + 1e-6 and est[j] + radius[j] >= hi_x - 1e-6, (k, row, ref)
        assert (row["flag"] == "observable") == bool(np.all(radius <= [0.5, 0.5]))
        if row["flag"] == "observable":
            assert abs(X[k, 0]) <= 0.5 + 1e-7
        checked += 1
    assert checked >= len(rows) - 4


def test_input_noise_bound_reaches_the_lookup_observer_and_nothing_else(tmp_path, capsys):
    _log(tmp_path / "log.csv", 0.01, N=20)
    base = ["observe", str(MODEL), "--data", str(tmp_path / "log.csv"), "-T", "3", "--json"]
    assert main(base + ["--observers", "lookup", "--noise-bound", "0.01", "--input-noise-bound", "u=0.05"]) == 0
    with_inputs = json.loads(capsys.readouterr().out)
    assert main(base + ["--observers", "lookup", "--noise-bound", "0.01"]) == 0
    without = json.loads(capsys.readouterr().out)
    # the inputs' noise widens the radii (x2 = y is pinned by the output alone, x1 is not)
    assert with_inputs["radius_max"][0] >= without["radius_max"][0] and with_inputs["radius_median"] != without["radius_median"]
    assert with_inputs["n_outside_radius"] == 0
    for extra, needle in ((["--observers", "lookup", "--input-noise-bound", "0.05"], "--noise-bound"),
                          (["--observers", "set_membership", "--noise-bound", "0.01", "--input-noise-bound", "0.05"],
                           "lookup"),
                          (["--observers", "lookup", "--noise-bound", "0.01", "--input-noise-bound", "v=0.05"], "'v'")):
        assert main(base + extra) == 2
        captured = capsys.readouterr()  # with --json the error is a JSON line on stdout
        assert needle in captured.out + captured.err
