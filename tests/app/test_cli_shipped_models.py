"""The literature systems shipped under examples/ through every command that applies to their class.

Each model file ``examples/models/<stem>.<toml|yaml|json>`` has a builder
``examples/builders/<stem>.py:build``; both name the same system.  The JSON fields asserted are
the ones users' scripts read.
"""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from hybobs_opt import load_model, resolve_system
from hybobs_opt.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted(p for p in (ROOT / "examples" / "models").glob("*") if p.suffix in (".toml", ".yaml", ".yml", ".json"))


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


def test_three_systems_in_three_formats_with_builders():
    assert len(MODELS) >= 3
    assert {p.suffix for p in MODELS} >= {".toml", ".json"} and ({".yaml", ".yml"} & {p.suffix for p in MODELS})
    classes = {load_model(p).to_dict()["class"] for p in MODELS}
    assert {"pwa", "scalar_nonlinear"} <= classes
    for p in MODELS:
        assert (ROOT / "examples" / "builders" / f"{p.stem}.py").is_file(), p


@pytest.mark.parametrize("path", MODELS, ids=[p.name for p in MODELS])
def test_model_file_equals_its_builder(path):
    built = resolve_system(f"{ROOT / 'examples' / 'builders' / path.stem}.py:build")
    loaded = load_model(path)
    a, b = loaded.to_dict(), built.to_dict()
    for key in ("class", "states", "inputs", "outputs"):
        assert a[key] == b[key]
    # the same dynamics on random points of the operating set (numbers may differ in the last bits)
    rng = np.random.default_rng(0)
    if a["class"] == "pwa":
        lo, hi = loaded.domain.bounding_box()
        for z in lo + (hi - lo) * rng.random((100, lo.size)):
            x, u = z[: loaded.n], z[loaded.n:]
            if loaded.modes_of(x, u)[0] >= 0:
                np.testing.assert_allclose(loaded.step(x, u), built.step(x, u), rtol=1e-12, atol=1e-12)
    elif a["class"] == "scalar_nonlinear":
        X = loaded.box_lower + (loaded.box_upper - loaded.box_lower) * rng.random((100, loaded.n))
        np.testing.assert_allclose(loaded.rhs(X, np.zeros(loaded.m)), built.rhs(X, np.zeros(built.m)), rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(loaded.output(X), built.output(X), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("path", MODELS, ids=[p.name for p in MODELS])
def test_every_applicable_command(path, capsys, tmp_path):
    check = run_json(capsys, "model", "check", path)
    kind = check["class"]
    assert check["valid"] is True and check["states"]

    horizon = ["--t-final", "3"] if kind == "hybrid_automaton" else []  # the water tanks are Zeno at t = 4 s from (1, 1)
    sim = run_json(capsys, "simulate", path, *horizon)
    x = np.asarray(sim["x"])
    assert sim["kind"] == kind and x.shape[1] == len(check["states"]) and np.all(np.isfinite(x))

    code, out, err = run(capsys, "report", path, "--out-dir", tmp_path / "report", "--json")
    rep = json.loads(out)
    keys = [r["key"] for r in rep["sections"]]
    assert keys[:2] == ["model", "simulation"]
    if kind == "hybrid_automaton":
        # the report's run from the centre of the state bounds reaches the tanks' Zeno point and
        # stops: the page says so, and the section is reported failed, not ok with an error inside
        model, simulation = rep["sections"]
        assert code == 2 and model["ok"] and not simulation["ok"]
        assert simulation["error"] == simulation["summary"]["error"] and "t = " in simulation["error"]
        assert "simulation" in rep["error"] and (tmp_path / "report" / "index.html").exists()
    else:
        assert code == 0, err
        assert all(r["ok"] for r in rep["sections"]), rep["sections"]

    if kind == "pwa":
        assert keys == ["model", "simulation", "regions"]
        regions = run_json(capsys, "regions", path, "-T", "2", "--executor", "serial", "--out", tmp_path / "r.json")
        assert regions["system"] == str(path) and regions["n_regions"] >= 1 and regions["saved"]
        log = tmp_path / "log.csv"
        system = load_model(path)
        lo, hi = system.input_bounds.bounding_box() if system.m else (np.zeros(0), np.zeros(0))
        U = lo + (hi - lo) * np.random.default_rng(1).random((80, system.m))
        xs0 = 0.5 * sum(system.state_bounds.bounding_box())
        from hybobs_opt import simulate_pwa

        trace = simulate_pwa(system, xs0, U, on_blocked="stop")
        trace.to_csv(log)
        obs = run_json(capsys, "observe", path, "--data", log, "--regions", tmp_path / "r.json", "--out", tmp_path / "e.csv")
        assert obs["n_samples"] == trace.n_samples and sum(obs["flag_counts"].values()) == trace.n_samples
        assert obs["has_true_states"] and obs["n_flagged_observable_wrong"] == 0
        rows = list(csv.DictReader((tmp_path / "e.csv").open()))
        assert len(rows) == trace.n_samples and {"mode", "flag", *check["states"]} <= set(rows[0])
        bench = run_json(capsys, "bench", path, "--data", log, "-T", "2", "--observers", "lookup,milp")
        assert set(bench["observers"]) == {"lookup", "milp"}
        for rec in bench["observers"].values():
            assert rec["n_flagged_observable_wrong"] == 0
    elif kind == "scalar_nonlinear":
        assert keys == ["model", "simulation", "diagnosis", "synthesis"]
        diag = run_json(capsys, "diagnose", path, "--out-dir", tmp_path / "diag")
        assert isinstance(diag["feasible"], bool) and diag["settings"]["source"] == "model"
        assert diag["settings"]["coordinate"] in check["states"]
        if not diag["feasible"]:
            assert "certificate" in diag
        synth = run_json(capsys, "synth", path, "--out", tmp_path / "gains.json")
        assert synth["regions"] and json.loads((tmp_path / "gains.json").read_text())["regions"]
        bound = synth["settings"]["gain_bound"]
        assert all(r["gain_norm"] <= bound * (1 + 1e-6) for r in synth["regions"])
        assert (synth["dwell_enforced"] is False) == bool(synth["warnings"])


def test_switched_gain_observer_on_a_log_of_the_robot(capsys, tmp_path):
    """observe --data on a scalar-nonlinear system: the CLI's estimates are SwitchedGainObserver.run's,
    and they converge to the logged states (the design is exponentially stable, Theorem 1)."""
    from hybobs_opt import SwitchedGainObserver, read_log
    from hybobs_opt.observers.recorded import gains_from_json, sample_period

    model = ROOT / "examples" / "models" / "flexible_joint_robot.toml"
    log, gains, est = tmp_path / "log.csv", tmp_path / "gains.json", tmp_path / "est.csv"
    assert run(capsys, "simulate", model, "--x0", "theta_l=1", "--x0", "theta_m=0.5", "--t-final", "2", "--ts", "0.001",
               "--out", log)[0] == 0
    assert run(capsys, "synth", model, "--out", gains)[0] == 0
    s = run_json(capsys, "observe", model, "--data", log, "--gains", gains, "--out", est)
    assert s["n_samples"] == 2001 and s["has_true_states"]
    assert max(s["final_abs_error"]) < 1e-4 and s["n_regions"] >= 1
    system = load_model(model)
    data = read_log(log, system)
    assert abs(sample_period(data) - 0.001) < 1e-15  # the period read from the time column
    direct = SwitchedGainObserver(system, gains_from_json(system, json.loads(gains.read_text())), sample_period(data))
    direct.reset()
    x_direct = direct.run(data.U, data.Y).x_hat
    rows = list(csv.DictReader(est.open()))
    np.testing.assert_array_equal(np.array([[float(r[n]) for n in system.state_names] for r in rows]), x_direct)
    # gains designed for another system are refused, naming the file (the file carries the
    # system's fingerprint and a checksum: an edit of the file is refused as an edit)
    from hybobs_opt.systems.fingerprint import system_fingerprint
    from hybobs_opt.systems.saved_file import content_checksum

    sealed = json.loads(gains.read_text())
    assert sealed["format"] == "hybobs_opt.gains" and sealed["system_fingerprint"] == system_fingerprint(system)
    other = dict(sealed, system_fingerprint=system_fingerprint(resolve_system("vehicle_tracking", {})))
    gains.write_text(json.dumps(dict(other, checksum=content_checksum(other))))
    code, _, err = run(capsys, "observe", model, "--data", log, "--gains", gains)
    assert code == 2 and "gains.json" in err and "another system" in err
    gains.write_text(json.dumps(dict(sealed, state_names=["a", "b", "c", "d"])))
    code, _, err = run(capsys, "observe", model, "--data", log, "--gains", gains)
    assert code == 2 and "gains.json" in err and "edited or corrupted" in err
