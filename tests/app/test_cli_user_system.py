"""Every command on a user's own system (issue 14): model files, PATH.py:FUNCTION, recorded logs.

The system is the rotating PWA example of Bemporad & Morari (Automatica 35(3), 1999, Sec. 5):
x(t+1) = 0.8 R(+-pi/3) x + [0; 1] u, the sign by x1 >= 0, y = x2, written here by hand (no
toolbox code) as a TOML file and as a Python builder.  Its mirror symmetry gives exact expected
answers: (x1, x2) and (-x1, x2) give the same outputs for every input, so no state off x1 = 0 is
observable at any horizon.
"""

import csv
import json
import math
import textwrap

import numpy as np
import pytest

from hybobs_opt import LookupObserver, analyse_observability, load_model, resolve_system
from hybobs_opt.cli import main

TOML = textwrap.dedent("""
    class = "pwa"
    name = "rotation"
    states = ["x1", "x2"]
    inputs = ["u"]
    outputs = ["y"]
    state_bounds = {box = {x1 = [-10, 10], x2 = [-10, 10]}}
    input_bounds = {box = {u = [-1, 1]}}

    [[modes]]
    name = "right"
    A = [[0.4, -0.6928203230275509], [0.6928203230275509, 0.4]]
    B = [[0.0], [1.0]]
    C = [[0.0, 1.0]]
    guard = {inequalities = ["x1 >= 0"]}

    [[modes]]
    name = "left"
    A = [[0.4, 0.6928203230275509], [-0.6928203230275509, 0.4]]
    B = [[0.0], [1.0]]
    C = [[0.0, 1.0]]
    guard = {inequalities = ["x1 <= 0"]}
""")

BUILDER = textwrap.dedent("""
    import math
    import numpy as np
    from hybobs_opt import PWAMode, PWASystem, Polytope

    def build(angle=math.pi / 3):
        def rot(a):
            return 0.8 * np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        B, C = np.array([[0.0], [1.0]]), np.array([[0.0, 1.0]])
        modes = (PWAMode(rot(angle), B, np.zeros(2), C, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.zeros(1)), name="right"),
                 PWAMode(rot(-angle), B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0]]), np.zeros(1)), name="left"))
        return PWASystem(modes, Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]),
                         ("x1", "x2"), ("u",), ("y",), name="rotation")

    def broken():
        raise RuntimeError("the plant data are missing")

    def not_a_system():
        return {"A": 1}
""")


def rot(a):
    return 0.8 * np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def simulate_by_hand(x0, U):
    """The published equations in numpy: x(t+1) = 0.8 R(+-pi/3) x + [0; 1] u, y = x2."""
    X, Y = [np.array(x0, float)], []
    for u in U:
        x = X[-1]
        Y.append(x[1])
        X.append(rot(math.pi / 3 if x[0] >= 0 else -math.pi / 3) @ x + np.array([0.0, u]))
    return np.array(X[:-1]), np.array(Y)


@pytest.fixture
def files(tmp_path):
    (tmp_path / "rotation.toml").write_text(TOML)
    (tmp_path / "plant.py").write_text(BUILDER)
    rng = np.random.default_rng(3)
    U = rng.uniform(-1, 1, 120)
    X, Y = simulate_by_hand([3.0, -2.0], U)
    with (tmp_path / "log.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "y", "u", "x1", "x2"])  # any column order
        for k in range(U.size):
            w.writerow([0.1 * k, repr(float(Y[k])), repr(float(U[k])), repr(float(X[k, 0])), repr(float(X[k, 1]))])
    return {"dir": tmp_path, "toml": str(tmp_path / "rotation.toml"), "py": str(tmp_path / "plant.py"),
            "log": str(tmp_path / "log.csv"), "U": U, "X": X, "Y": Y}


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_model_file_and_builder_are_the_same_system(files):
    a = load_model(files["toml"])
    b = resolve_system(f"{files['py']}:build")
    np.testing.assert_allclose(a.modes[0].A, b.modes[0].A, atol=1e-15)
    rng = np.random.default_rng(0)
    for _ in range(50):
        x, u = rng.uniform(-10, 10, 2), rng.uniform(-1, 1, 1)
        want = rot(math.pi / 3 if x[0] >= 0 else -math.pi / 3) @ x + np.array([0.0, u[0]])
        np.testing.assert_allclose(a.step(x, u), want, atol=1e-12)
        np.testing.assert_allclose(b.step(x, u), want, atol=1e-12)


@pytest.mark.parametrize("form", ["toml", "py"])
def test_simulate_matches_the_hand_written_equations(files, capsys, form):
    name = files["toml"] if form == "toml" else f"{files['py']}:build"
    code, out, err = run(capsys, "simulate", name, "--x0", "x1=3", "--x0", "x2=-2", "--u", "u=0.5", "--steps", "25", "--json")
    assert code == 0, err
    data = json.loads(out)
    X, Y = simulate_by_hand([3.0, -2.0], np.full(25, 0.5))
    np.testing.assert_allclose(np.asarray(data["x"]), X, atol=1e-12)
    np.testing.assert_allclose(np.asarray(data["y"])[:, 0], Y, atol=1e-12)
    assert data["system"] == name and data["kind"] == "pwa"


def test_regions_json_and_two_state_plot(files, capsys):
    png = files["dir"] / "cut.png"
    code, out, err = run(capsys, "regions", files["toml"], "-T", "3", "--executor", "serial", "--plot", png, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["system"] == files["toml"] and data["n_regions"] >= 4
    # mirror symmetry: nothing off the line x1 = 0 is observable, whatever the horizon
    assert data["cut"]["fraction_observable_of_feasible"] < 0.05
    assert png.stat().st_size > 1000


def test_observe_csv_reproduces_run_and_is_right_where_flagged(files, capsys):
    est = files["dir"] / "est.csv"
    code, out, err = run(capsys, "observe", files["toml"], "--data", files["log"], "--observers", "lookup",
                         "--horizon", "2", "--out", est, "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["n_samples"] == 120 and summary["has_true_states"] is True
    assert sum(summary["flag_counts"].values()) == 120
    system = load_model(files["toml"])
    direct = LookupObserver(analyse_observability(system, 2)).run(files["U"][:, None], files["Y"][:, None])
    rows = list(csv.DictReader(est.open()))
    x_cli = np.array([[float(r["x1"]), float(r["x2"])] for r in rows])
    np.testing.assert_array_equal(x_cli, direct.x_hat)  # exact: 17 significant digits in the file
    assert [r["flag"] for r in rows] == list(direct.flags)
    assert summary["flag_counts"]["observable"] == int(np.sum(direct.flags == "observable"))
    # no state off x1 = 0 is observable (mirror symmetry), so nothing may be flagged observable here
    assert summary["flag_counts"]["observable"] == 0


@pytest.mark.parametrize("observer", ["miqp", "milp"])
def test_mhe_on_the_log_is_exact_where_flagged(files, capsys, observer):
    code, out, err = run(capsys, "observe", files["toml"], "--data", files["log"], "--observers", observer,
                         "--horizon", "3", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert s["n_flagged_observable_wrong"] == 0
    if s["max_rel_error_observable"] is not None:
        assert s["max_rel_error_observable"] < 1e-8


def test_bench_compares_observers_on_the_same_log(files, capsys):
    code, out, err = run(capsys, "bench", files["toml"], "--data", files["log"], "-T", "2", "--observers", "lookup,milp", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert set(s["observers"]) == {"lookup", "milp"} and s["steps"] == 120
    assert s["observers"]["lookup"]["ratio_to_lookup"] == 1.0
    for rec in s["observers"].values():
        assert sum(rec["flag_counts"].values()) == 120


def test_report_of_the_system(files, capsys):
    out_dir = files["dir"] / "report"
    code, out, err = run(capsys, "report", files["toml"], "--out-dir", out_dir, "--data", files["log"], "--json")
    assert code == 0, err
    keys = [r["key"] for r in json.loads(out)["sections"]]
    assert keys == ["model", "simulation", "regions", "observers"]
    assert (out_dir / "index.html").exists()
    from tests.check_links import check_html_tree  # every link and image resolves, every alt says what it shows
    from tests.check_report_text import literal_problems, table_problems, visible_text

    assert check_html_tree(out_dir) == []
    page = (out_dir / "index.html").read_text()
    assert literal_problems(visible_text(page)) == [] and table_problems(page) == []


def test_report_with_a_noise_bound_states_radii_that_hold(files, capsys):
    """``report SYSTEM --data LOG --noise-bound``: every observer states radii, the set-membership
    observer joins them, the true states of the log lie within every radius, and the page says so."""
    out_dir = files["dir"] / "report_bounded"
    code, out, err = run(capsys, "report", files["toml"], "--out-dir", out_dir, "--data", files["log"], "-T", "3",
                         "--noise-bound", "y=0.001", "--json")
    assert code == 0, err
    sections = {r["key"]: r for r in json.loads(out)["sections"]}
    assert sections["observers"]["ok"], sections["observers"]
    page = (out_dir / "index.html").read_text()
    assert "true state outside the radius [samples]" in page and "|noise of y| &lt;= 0.001" in page
    summary = sections["observers"]["summary"]
    assert set(summary) == {"lookup", "miqp", "milp", "set_membership"}
    for kind, rec in summary.items():
        assert rec["n_outside_radius"] == 0 and len(rec["radius_max"]) == 2, kind
    from tests.check_links import check_html_tree

    assert check_html_tree(out_dir) == []


def test_model_export_then_check_round_trip(files, capsys):
    target = files["dir"] / "copy.json"
    assert run(capsys, "model", "export", f"{files['py']}:build", "--param", "angle=1.0471975511965976", "--out", target)[0] == 0
    code, out, _ = run(capsys, "model", "check", target, "--json")
    assert code == 0 and json.loads(out)["n_modes"] == 2


def bad_csv(files, name, header, rows):
    path = files["dir"] / name
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return str(path)


@pytest.mark.parametrize("case", ["unknown path", "missing py", "raises", "wrong type", "unknown function",
                                  "malformed toml", "bad entry", "csv missing column", "csv extra column",
                                  "csv nan", "csv text", "param to file", "wrong class for regions"])
def test_bad_input_exit_2_one_line_naming_file_and_entry(files, capsys, case):
    d = files["dir"]
    if case == "malformed toml":
        (d / "m.toml").write_text("class = 'pwa'\nstates = [x1\n")
    if case == "bad entry":
        (d / "e.toml").write_text(TOML.replace("C = [[0.0, 1.0]]", "C = [[0.0, 1.0, 2.0]]", 1))
    argv, fragments = {
        "unknown path": (["simulate", d / "nowhere.toml"], ["nowhere.toml"]),
        "missing py": (["simulate", f"{d / 'nowhere.py'}:build"], ["nowhere.py"]),
        "raises": (["simulate", f"{files['py']}:broken"], ["plant.py:broken", "plant data are missing"]),
        "wrong type": (["simulate", f"{files['py']}:not_a_system"], ["not_a_system", "dict"]),
        "unknown function": (["simulate", f"{files['py']}:nope"], ["plant.py:nope", "build"]),
        "malformed toml": (["simulate", d / "m.toml"], ["m.toml", "TOML"]),
        "bad entry": (["simulate", d / "e.toml"], ["e.toml", "modes[0].C"]),
        "csv missing column": (["observe", files["toml"], "--data", bad_csv(files, "missing.csv", ["u", "x1"], [[0.1, 0.2]])], ["missing.csv", "'y'"]),
        "csv extra column": (["observe", files["toml"], "--data", bad_csv(files, "extra.csv", ["u", "y", "speed"], [[0.1, 0.2, 1.0]])], ["extra.csv", "speed"]),
        "csv nan": (["observe", files["toml"], "--data", bad_csv(files, "nan.csv", ["u", "y"], [[0.1, 0.2], [0.1, "nan"]])], ["nan.csv", "line 3", "'y'"]),
        "csv text": (["observe", files["toml"], "--data", bad_csv(files, "text.csv", ["u", "y"], [["fast", 0.2]])], ["text.csv", "line 2", "'u'"]),
        "param to file": (["simulate", files["toml"], "--param", "angle=1"], ["rotation.toml", "params"]),
        "wrong class for regions": (["regions", "vehicle_tracking", "-T", "2"], ["PWA", "scalar-nonlinear"]),
    }[case]
    code, _, err = run(capsys, *argv)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


def test_a_simulate_csv_is_a_log_and_a_conflicting_duplicate_column_is_refused(capsys, tmp_path):
    """powertrain3's output is also a state (omega_m): the trace CSV holds that column twice, with the same values."""
    run_csv = tmp_path / "run.csv"
    assert run(capsys, "simulate", "powertrain3", "--t-final", "0.05", "--out", run_csv)[0] == 0
    code, out, err = run(capsys, "observe", "powertrain3", "--data", run_csv, "--json")
    assert code == 0, err
    s = json.loads(out)
    assert s["has_true_states"] and s["n_samples"] == 50 and s["n_flagged_observable_wrong"] == 0
    rows = list(csv.reader(run_csv.open()))
    last = rows[0].index("omega_m", rows[0].index("omega_m") + 1)  # the output copy of omega_m
    rows[7][last] = str(float(rows[7][last]) + 1.0)
    with run_csv.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    code, _, err = run(capsys, "observe", "powertrain3", "--data", run_csv)
    assert code == 2 and "line 8" in err and "'omega_m'" in err and len(err.strip().splitlines()) == 1


def test_saved_regions_feed_the_observer_and_refuse_another_plant(files, capsys):
    saved = files["dir"] / "regions.json"
    assert run(capsys, "regions", files["toml"], "-T", "2", "--executor", "serial", "--out", saved)[0] == 0
    code, out, err = run(capsys, "observe", files["toml"], "--data", files["log"], "--regions", saved, "--json")
    assert code == 0, err
    assert json.loads(out)["horizon"] == 2
    # the same file for the plant with another rotation angle (pi/4): refused, naming the entry that differs
    code, _, err = run(capsys, "observe", f"{files['py']}:build", "--param", "angle=0.7853981633974483",
                       "--data", files["log"], "--regions", saved)
    assert code == 2 and "another system" in err and "modes[0].A" in err and len(err.strip().splitlines()) == 1
    # one number edited in the file: refused
    data = json.loads(saved.read_text())
    data["regions"][0]["H"][0][0] += 1e-9
    saved.write_text(json.dumps(data))
    code, _, err = run(capsys, "observe", files["toml"], "--data", files["log"], "--regions", saved)
    assert code == 2 and "checksum" in err


NAMED_BUILDER = textwrap.dedent("""
    import math
    import numpy as np
    from hybobs_opt import PWAMode, PWASystem, Polytope

    def build(name: str = "rotation", angle=math.pi / 3):
        def rot(a):
            return 0.8 * np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        B, C = np.array([[0.0], [1.0]]), np.array([[0.0, 1.0]])
        modes = (PWAMode(rot(angle), B, np.zeros(2), C, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.zeros(1)), name="right"),
                 PWAMode(rot(-angle), B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0]]), np.zeros(1)), name="left"))
        return PWASystem(modes, Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]),
                         ("x1", "x2"), ("u",), ("y",), name=name)
""")


def test_param_passes_text_to_a_string_parameter_and_numbers_stay_numbers(capsys, tmp_path):
    (tmp_path / "named.py").write_text(NAMED_BUILDER)
    target = f"{tmp_path / 'named.py'}:build"
    code, out, err = run(capsys, "model", "check", target, "--param", "name=left arm", "--param", "angle=1/3", "--json")
    assert code == 0, err
    assert json.loads(out)["name"] == "left arm"
    # text for a parameter that is not a string is refused, naming the option and the value
    code, out, err = run(capsys, "model", "check", target, "--param", "angle=wide")
    assert code == 2 and "--param angle" in err and "'wide'" in err and "not a string" in err, err
    # an example's parameters are numbers
    code, out, err = run(capsys, "model", "check", "powertrain3", "--param", "gear_ratio=abc")
    assert code == 2 and "--param gear_ratio" in err and "a number" in err, err


def test_model_export_creates_missing_directories(capsys, tmp_path):
    path = tmp_path / "new" / "deeper" / "rotation.toml"
    code, out, err = run(capsys, "model", "export", "powertrain3", "-o", path, "--json")
    assert code == 0, err
    assert json.loads(out)["written"] == str(path) and path.is_file()
    code, out, err = run(capsys, "model", "check", path, "--json")
    assert code == 0 and json.loads(out)["n_modes"] == 3, err
    # a parent that is a file cannot become a directory: refused before any work
    (tmp_path / "plain").write_text("x")
    code, out, err = run(capsys, "model", "export", "powertrain3", "--out", tmp_path / "plain" / "m.toml")
    assert code == 2 and "--out" in err, err
