"""The hybobs command: the JSON contract, exit codes, the report."""

import json

import numpy as np
import pytest

from hybobs_opt.cli import main

EXAMPLE_NAMES = {
    "powertrain3", "powertrain5", "driveline", "switched_unstable", "triangular", "double_scroll",
    "switching_server", "traffic_junction", "vehicle_tracking", "magnetic_piston",
}


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_examples_json_contract(capsys):
    code, out, _ = run(capsys, "examples", "--json")
    assert code == 0
    records = json.loads(out)
    assert {r["name"] for r in records} == EXAMPLE_NAMES
    for r in records:
        assert {"name", "kind", "paper", "n_states", "state_names"} <= set(r)
        assert r["n_states"] == len(r["state_names"])
    by_name = {r["name"]: r for r in records}
    assert by_name["powertrain3"]["state_names"] == ["theta", "omega_m", "omega_l"]
    assert by_name["powertrain5"]["state_names"] == ["theta_mc", "theta_cl", "omega_m", "omega_c", "omega_l"]


def test_simulate_json_arrays(capsys):
    code, out, _ = run(capsys, "simulate", "powertrain3", "--t-final", "0.5", "--json")
    assert code == 0
    data = json.loads(out)
    t, x, q, u, y = (np.asarray(data[k]) for k in ("t", "x", "q", "u", "y"))
    assert t.shape == (500,) and x.shape == (500, 3) and q.shape == (500,) and u.shape == (500, 1)
    np.testing.assert_allclose(y[:, 0], x[:, 1])  # the output is the engine speed


def test_simulate_param_changes_model(capsys):
    _, a, _ = run(capsys, "simulate", "powertrain3", "--t-final", "0.2", "--json")
    _, b, _ = run(capsys, "simulate", "powertrain3", "--t-final", "0.2", "--param", "gear_ratio=1/2", "--json")
    assert json.loads(a)["x"][-1] != json.loads(b)["x"][-1]


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["simulate", "no_such_example"], "one of"),
        (["simulate", "powertrain3", "--param", "gear_ratio"], "--param"),
        (["simulate", "powertrain3", "--param", "warp=2"], "parameters"),
        (["simulate", "powertrain3", "--t-final", "-1"], "--t-final"),
        (["observe", "traffic_light"], "one of"),
    ],
)
def test_bad_input_one_line_and_exit_2(capsys, argv, fragment):
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert fragment in err
    assert len(err.strip().splitlines()) == 1


def test_simulate_writes_plot_and_csv(capsys, tmp_path):
    png, csv = tmp_path / "p.png", tmp_path / "p.csv"
    code, _, _ = run(capsys, "simulate", "powertrain3", "--t-final", "0.1", "--plot", str(png), "--out", str(csv))
    assert code == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    header = csv.read_text().splitlines()[0].split(",")
    assert header == ["t", "theta", "omega_m", "omega_l", "q", "T_m", "omega_m"]


@pytest.mark.slow
def test_report_command_builds_the_chosen_section(capsys, tmp_path):
    # the CLI path with one section; every section is built (and checked) once, through
    # build_report, by the fixture of tests/app/test_report_figures.py
    code, out, _ = run(capsys, "report", "--out-dir", str(tmp_path / "rep"), "--section", "examples", "--json")
    data = json.loads(out)
    assert code == 0, [s["error"] for s in data["sections"] if not s["ok"]]
    assert [s["key"] for s in data["sections"]] == ["examples"]
    index = (tmp_path / "rep" / "index.html").read_text()
    for name in EXAMPLE_NAMES:
        assert f"example_{name}.png" in index
        assert (tmp_path / "rep" / f"example_{name}.png").stat().st_size > 1000
