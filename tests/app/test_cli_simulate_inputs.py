"""``hybobs simulate SYSTEM --inputs U.csv``: time-varying inputs from a CSV (one column per input,
a time column t; each row held until the next), validated with errors naming the row and column."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hybobs_opt.cli import main

ROTATION = "examples/models/bemporad_morari_rotation.toml"
ROBOT = "examples/models/flexible_joint_robot.toml"
TANKS = "examples/models/water_tanks.toml"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def by_hand(x0, U):
    """Bemporad & Morari's rotation system written out: x(t+1) = 0.8 R(+-pi/3) x + [0; 1] u."""
    def rot(a):
        return 0.8 * np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])

    X = [np.array(x0, float)]
    for u in U:
        x = X[-1]
        X.append(rot(math.pi / 3 if x[0] >= 0 else -math.pi / 3) @ x + np.array([0.0, u]))
    return np.array(X[:-1])


def test_pwa_runs_one_sample_per_row(capsys, tmp_path):
    U = [0.5, -0.25, 1.0, 0.0, -1.0]
    path = tmp_path / "u.csv"
    path.write_text("u\n" + "".join(f"{u}\n" for u in U))
    code, out, err = run(capsys, "simulate", ROTATION, "--x0", "x1=3", "--x0", "x2=-2", "--inputs", path, "--json")
    assert code == 0, err
    trace = json.loads(out)
    assert np.allclose(np.array(trace["u"])[:, 0], U)
    assert np.allclose(np.array(trace["x"])[: len(U)], by_hand([3.0, -2.0], U), atol=1e-12)


def test_continuous_time_input_holds_each_row_until_the_next(capsys, tmp_path):
    path = tmp_path / "u.csv"
    path.write_text("t,u\n0,0.0\n0.1,2.0\n0.2,-1.0\n")
    code, out, err = run(capsys, "simulate", ROBOT, "--inputs", path, "--ts", "0.01", "--json")
    assert code == 0, err
    trace = json.loads(out)
    t, u = np.array(trace["t"]), np.array(trace["u"])[:, 0]
    assert t[-1] == pytest.approx(0.2)  # default final time: the last row's
    assert np.all(u[t < 0.1 - 1e-9] == 0.0)
    assert np.all(u[(t > 0.1 + 1e-9) & (t < 0.2 - 1e-9)] == 2.0)


def test_a_constant_table_is_the_constant_input(capsys, tmp_path):
    path = tmp_path / "u.csv"
    path.write_text("u,t\n0.3,0\n0.3,0.05\n0.3,0.1\n")
    _, table, _ = run(capsys, "simulate", ROBOT, "--inputs", path, "--ts", "0.01", "--json")
    _, const, _ = run(capsys, "simulate", ROBOT, "--u", "u=0.3", "--t-final", "0.1", "--ts", "0.01", "--json")
    a, b = json.loads(table), json.loads(const)
    assert np.allclose(a["t"], b["t"]) and np.allclose(a["x"], b["x"], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("system, text, extra, needles", [
    (ROTATION, "u,v\n1,2\n", [], ["header", "unknown ['v']"]),
    (ROTATION, "t\n0\n", [], ["header", "missing ['u']"]),
    (ROTATION, "u\n1\nabc\n", [], ["line 3 column 'u'", "finite number", "'abc'"]),
    (ROTATION, "u\n1\nnan\n", [], ["line 3 column 'u'", "finite number"]),
    # the number grammar of every file the toolbox reads: Python's float() would take 1_0 as 10
    (ROTATION, "u\n1\n1_0\n", [], ["line 3 column 'u'", "ASCII decimal digits", "'1_0'"]),
    (ROTATION, "u\n1\n2,3\n", [], ["line 3", "1 cells"]),
    (ROTATION, "u\n", [], ["at least one row"]),
    (ROTATION, "u\n1\n", ["--steps", "5"], ["--steps", "one sample per row"]),
    (ROTATION, "u\n1\n", ["--u", "u=1"], ["--u", "--inputs"]),
    (ROBOT, "u\n1\n", [], ["time column t"]),
    (ROBOT, "t,u\n0,1\n0.2,1\n0.1,1\n", [], ["line 4 column 't'", "strictly increasing"]),
    (ROBOT, "t,u\n0.5,1\n1,1\n", [], ["line 2 column 't'", "starting at 0"]),
    (ROBOT, "t,u\n0,1\n0.1,1\n", ["--t-final", "1"], ["--t-final", "last time of the input table"]),
    (TANKS, "u\n1\n", [], ["--inputs", "no inputs"]),
    ("powertrain3", "T_m\n1\n", [], ["--inputs", "powertrain3"]),
])
def test_bad_tables_are_one_line_naming_row_and_column(capsys, tmp_path, system, text, extra, needles):
    path = tmp_path / "u.csv"
    path.write_text(text)
    code, out, err = run(capsys, "simulate", system, "--inputs", path, *extra)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
