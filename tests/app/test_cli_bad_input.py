"""Every bad input of ``hybobs`` exits 2 with one line (issue 16).

One line on stderr (``hybobs CMD: error: ...``), or under ``--json`` one JSON object on stdout with
``error`` (and ``command``, ``field`` ...).  Unknown choices are rejected with the valid ones
listed, options that do not apply to the chosen example, system or observer are rejected, and
resource-absurd requests are refused before anything is allocated.

First one regression test per defect of the issue's campaign (each failed before the fix: a
traceback, an exit 0, a multi-line argparse error, plain text under ``--json`` or the wrong
flag), then the campaign of this change as a table: every row fails during validation, so the
whole file runs in seconds (no scenario, analysis or LMI is computed).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybobs_opt.cli import main
from hybobs_opt.limits import MAX_HORIZON, MAX_SAMPLES

MODELS = Path(__file__).resolve().parents[2] / "examples" / "models"
PWA_MODEL = str(MODELS / "bemporad_morari_rotation.toml")  # x1, x2; u; y; no Ts
HYBRID_MODEL = str(MODELS / "water_tanks.toml")  # x1, x2 in [0, 2]; no input
NONLINEAR_MODEL = str(MODELS / "flexible_joint_robot.toml")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def one_line_error(capsys, *argv) -> str:
    """The error line of a bad invocation (asserting exit 2 and exactly one non-empty stderr line)."""
    code, out, err = run(capsys, *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, out[:300], err)
    assert len(lines) == 1, err
    return lines[0]


def json_error(capsys, *argv) -> dict:
    """The JSON error object of a bad invocation under ``--json`` (exit 2, one JSON object on stdout)."""
    code, out, err = run(capsys, *argv)
    assert code == 2, (code, out[:300], err)
    record = json.loads(out)
    assert isinstance(record, dict) and record["error"], out
    return record


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_input")
    binary = b"\x00\x01\x02\xff\xfe binary \x89PNG\x00"
    paths = {"dir": d}
    for name in ("bin.csv", "bin.toml", "bin.json"):
        (d / name).write_bytes(binary)
        paths[name] = d / name
    for name in ("empty.csv", "empty.toml", "empty.json"):
        (d / name).write_text("")
        paths[name] = d / name
    (d / "header_only.csv").write_text("theta,omega_m\n")
    paths["header_only.csv"] = d / "header_only.csv"
    (d / "not_gains.json").write_text('{"a": 1}')
    paths["not_gains.json"] = d / "not_gains.json"
    (d / "a_file").write_text("x")
    paths["a_file"] = d / "a_file"
    # logs: the PWA model (20 samples) and the piston (51 samples), written by simulate --out
    paths["pwa.csv"], paths["piston.csv"] = d / "pwa.csv", d / "piston.csv"
    assert main(["simulate", PWA_MODEL, "--steps", "20", "--out", str(paths["pwa.csv"])]) == 0
    assert main(["simulate", "magnetic_piston", "--t-final", "0.05", "--out", str(paths["piston.csv"])]) == 0
    return paths


# ------------------------------------------------------------------ the defects of the issue, one test each
def test_param_fraction_with_zero_denominator(capsys):
    """Was ZeroDivisionError."""
    line = one_line_error(capsys, "simulate", "powertrain3", "--param", "gear_ratio=1/0")
    assert line.startswith("hybobs simulate: error: --param gear_ratio:") and "denominator" in line


def test_simulate_t_final_1e12_is_refused_before_allocating(capsys):
    """Was a MemoryError (7 PiB); the error says the samples asked and the limit."""
    line = one_line_error(capsys, "simulate", "powertrain3", "--t-final", "1e12")
    assert "--t-final" in line and f"{MAX_SAMPLES:,}" in line and "1e+15 samples" in line
    record = json_error(capsys, "simulate", "powertrain3", "--t-final", "1e12", "--json")
    assert record["field"] == "--t-final" and record["command"] == "simulate" and "MAX_SAMPLES" in record["expected"]


def test_model_file_run_of_1e12_s_is_refused_too(capsys):
    """The core simulators check the grid size (was a MemoryError of 728 TiB)."""
    line = one_line_error(capsys, "simulate", HYBRID_MODEL, "--t-final", "1e12")
    assert "--t-final / --ts" in line and "samples" in line


def test_plot_with_unknown_extension_is_refused_before_the_run(capsys, tmp_path):
    """Was matplotlib's ValueError after the simulation."""
    line = one_line_error(capsys, "simulate", "powertrain3", "--t-final", "0.01", "--plot", tmp_path / "p.xyz")
    assert "--plot" in line and ".png" in line and ".pdf" in line
    assert not (tmp_path / "p.xyz").exists()


def test_binary_query_file(capsys, files):
    """Was UnicodeDecodeError."""
    line = one_line_error(capsys, "regions", "powertrain3", "-T", "3", "--executor", "serial", "--query", files["bin.csv"])
    assert "--query" in line and "UTF-8" in line


def test_binary_model_file(capsys, files):
    """Was UnicodeDecodeError."""
    line = one_line_error(capsys, "model", "check", files["bin.toml"])
    assert "bin.toml" in line and "UTF-8" in line


def test_scheduler_nonsense(capsys):
    """Was a ValueError of distributed ('missing port number')."""
    line = one_line_error(capsys, "regions", "powertrain3", "-T", "3", "--scheduler", "nonsense")
    assert "--scheduler" in line and "tcp" in line and "HOST:PORT" in line


def test_bench_negative_seed(capsys):
    """Was numpy's ValueError ('expected non-negative integer') once noise was drawn."""
    line = one_line_error(capsys, "bench", "powertrain3", "--seed", "-1", "--noise", "0.1")
    assert "--seed" in line and "non-negative" in line


def test_regions_huge_horizon(capsys):
    """Was a MemoryError (7 TiB) in the first LP."""
    line = one_line_error(capsys, "regions", "powertrain3", "-T", "1000000")
    assert "--horizon" in line and str(MAX_HORIZON) in line


def test_bench_huge_steps(capsys):
    """Was a MemoryError (7 TiB) building the scenario."""
    line = one_line_error(capsys, "bench", "powertrain3", "--steps", "1000000000000")
    assert "--steps" in line and f"{MAX_SAMPLES:,}" in line


def test_t_final_below_one_sample(capsys):
    """Was an IndexError (a scenario of zero samples)."""
    line = one_line_error(capsys, "simulate", "powertrain3", "--t-final", "1e-9")
    assert "--t-final" in line and "sample period" in line


def test_pwa_initial_state_outside_the_bounds(capsys):
    """Was a ValueError reshaping an empty trace."""
    line = one_line_error(capsys, "simulate", PWA_MODEL, "--x0", "x1=1e300")
    assert "--x0" in line and "X x U" in line


def test_huge_gain_bound(capsys):
    """Was an OverflowError squaring the bound in the polytopic LMI."""
    line = one_line_error(capsys, "diagnose", "vehicle_tracking", "--settings", "model", "--gain-bound", "1e300")
    assert "--gain-bound" in line and "MAX_GAIN_BOUND" in line


def test_report_unknown_section(capsys, tmp_path):
    """Wrote an empty report and exited 0."""
    line = one_line_error(capsys, "report", "--out-dir", tmp_path / "rep", "--section", "nosuch")
    assert "--section" in line and "'nosuch'" in line and "examples" in line and "regions" in line
    assert not (tmp_path / "rep" / "index.html").exists()


def test_observe_driveline_unknown_observer(capsys):
    """The scenario ignored --observer and exited 0."""
    line = one_line_error(capsys, "observe", "driveline", "--observers", "nosuch")
    assert "--observer" in line and "hybrid" in line


def test_bench_empty_observer_list(capsys):
    """Ran no observer and exited 0."""
    line = one_line_error(capsys, "bench", "powertrain3", "--observers", "")
    assert "--observers" in line and "lookup, miqp, milp, milp_inf" in line


def test_bench_negative_mhe_steps(capsys):
    """Ran every step (``mhe_steps or steps``) and exited 0."""
    line = one_line_error(capsys, "bench", "powertrain3", "--mhe-steps", "-5")
    assert "--mhe-steps" in line and "positive" in line


def test_observe_powertrain_unknown_observer_names_its_own_flag(capsys):
    """Names the option of observe (--observers, a list with one name here)."""
    line = one_line_error(capsys, "observe", "powertrain3", "--observers", "nosuch")
    assert "--observers:" in line and "lookup, miqp, milp, milp_inf" in line


@pytest.mark.parametrize("argv, field", [
    (["simulate"], "SYSTEM"),
    (["simulate", "powertrain3", "--t-final", "abc"], "--t-final"),
    (["simulate", "powertrain3", "--nosuch"], "--nosuch"),
    (["regions", "powertrain3", "-T"], "--horizon"),  # -T has a default now (DEFAULT_HORIZON), not a value
    (["synth", "vehicle_tracking"], "--out"),
    (["nosuchcommand"], "COMMAND"),
])
def test_argparse_errors_are_one_line_and_json(capsys, argv, field):
    """argparse printed usage + error (2-7 lines) and plain text under --json."""
    line = one_line_error(capsys, *argv)
    assert field in line and "--help" in line
    record = json_error(capsys, *argv, "--json")
    assert record["field"] == field and record["kind"] == "usage"


def test_json_error_of_a_model_error(capsys):
    """Under --json the error was plain text on stderr."""
    record = json_error(capsys, "simulate", "no_such_example", "--json")
    assert record["command"] == "simulate" and record["field"] == "SYSTEM" and record["kind"] == "ModelError"
    assert "powertrain3" in record["expected"] and record["got"] == "'no_such_example'"
    assert record["error"].startswith("SYSTEM: expected")


def test_help_still_exits_0(capsys):
    code, out, _ = run(capsys, "observe", "--help")
    assert code == 0 and "usage: hybobs observe" in out
    assert "powertrain3: lookup, miqp, milp, milp_inf" in out and "traffic_junction: paper" in out
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "simulate" in out


def test_examples_declare_their_observer_kinds():
    """The kinds the CLI checks (Example.observers) are the ones the scenarios accept."""
    from hybobs_opt.studies import list_examples
    from hybobs_opt.studies.paper003_switching.scenarios import OBSERVER_KINDS

    by_name = {ex.name: ex for ex in list_examples()}
    assert set(by_name["traffic_junction"].observers) == set(OBSERVER_KINDS) | {f"{k}+projection" for k in OBSERVER_KINDS}
    assert by_name["powertrain3"].observers == ("lookup", "miqp", "milp", "milp_inf")
    assert all(ex.observers and ex.sample_time for ex in by_name.values())
    assert [ex.name for ex in by_name.values() if ex.observer_filter] == ["switched_unstable", "triangular", "double_scroll"]


# ------------------------------------------------------------------ the campaign
#: ``(argv, fragment)``: every row exits 2 with one line naming the field or the valid choices.
#: ``{name}`` stands for a file of the ``files`` fixture.
CAMPAIGN = [
    # argparse
    (["simulate", "powertrain3", "--t-final"], "expected one argument"),
    (["simulate", "powertrain3", "--steps", "1.5"], "invalid int value"),
    (["regions", "powertrain3", "-T", "3", "--executor", "nosuch"], "choose from 'serial', 'processes'"),
    (["diagnose", "vehicle_tracking", "--settings", "nosuch"], "choose from 'paper', 'model'"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--condition", "nosuch"], "'per_function'"),
    (["model", "nosuch"], "choose from 'schema', 'check', 'export'"),
    (["model"], "action"),
    (["examples", "extra"], "unrecognized arguments"),
    (["report"], "--out-dir"),
    # systems and --param
    (["simulate", "no_such_example"], "magnetic_piston"),
    (["simulate", "{nosuch.toml}"], "readable model file"),
    (["simulate", "{bin.json}"], "UTF-8"),
    (["simulate", "{empty.toml}"], "class"),
    (["simulate", "{empty.json}"], "well-formed JSON"),
    (["simulate", "nosuch.py:build"], "existing Python file"),
    (["simulate", "nosuchmodule_xyz:f"], "module:FUNCTION"),
    (["simulate", "powertrain3", "--param", "gear_ratio"], "NAME=VALUE"),
    (["simulate", "powertrain3", "--param", "=3"], "parameter name"),
    (["simulate", "powertrain3", "--param", "warp=2"], "gear_ratio"),
    (["simulate", "powertrain3", "--param", "gear_ratio=abc"], "--param gear_ratio"),
    (["simulate", "powertrain3", "--param", "gear_ratio=0/0"], "denominator"),
    (["simulate", "powertrain3", "--param", "gear_ratio=nan"], "gear_ratio"),
    (["simulate", "powertrain3", "--param", "gear_ratio=-1"], "gear_ratio"),
    (["simulate", "switched_unstable", "--param", "as_printed=2"], "0 or 1"),
    (["simulate", "traffic_junction", "--param", "lam=2"], "3 comma-separated numbers"),
    (["simulate", "traffic_junction", "--param", "lam=1,2"], "3 comma-separated numbers"),
    (["simulate", "vehicle_tracking", "--param", "delta_max_deg=90"], "--param delta_max_deg"),
    (["simulate", "vehicle_tracking", "--param", "delta_max_deg=1e300"], "--param delta_max_deg"),
    (["simulate", "magnetic_piston", "--param", "v_max=0"], "--param v_max"),
    (["simulate", "driveline", "--param", "Je=0"], "Je"),
    # simulate
    (["simulate", "powertrain3", "--t-final", "nan"], "--t-final"),
    (["simulate", "powertrain3", "--t-final", "inf"], "--t-final"),
    (["simulate", "powertrain3", "--t-final", "0"], "--t-final"),
    (["simulate", "powertrain3", "--t-final", "1e308"], "MAX_SAMPLES"),
    (["simulate", "switching_server", "--t-final", "1e12"], "MAX_SAMPLES"),
    (["simulate", "traffic_junction", "--t-final", "1e9"], "MAX_SAMPLES"),
    (["simulate", "powertrain3", "--x0", "theta=1"], "--x0"),
    (["simulate", "powertrain3", "--t-final", "0.01", "--plot", "{dir}/p"], ".png"),
    (["simulate", "powertrain3", "--t-final", "0.01", "--out", "{dir}"], "--out"),
    (["simulate", HYBRID_MODEL, "--ts", "1e-12"], "MAX_SAMPLES"),
    (["simulate", HYBRID_MODEL, "--ts", "0"], "--ts"),
    (["simulate", HYBRID_MODEL, "--ts", "nan"], "--ts"),
    (["simulate", HYBRID_MODEL, "--t-final", "1e-300"], "sample period"),
    (["simulate", HYBRID_MODEL, "--q0", "7"], "0..1"),
    (["simulate", HYBRID_MODEL, "--q0", "-1"], "0..1"),
    (["simulate", HYBRID_MODEL, "--x0", "x1=nan"], "--x0 x1"),
    (["simulate", HYBRID_MODEL, "--x0", "x1=1e300"], "[0, 2]"),
    (["simulate", HYBRID_MODEL, "--x0", "nosuch=1"], "x1"),
    (["simulate", HYBRID_MODEL, "--x0", "x1"], "NAME=VALUE"),
    (["simulate", HYBRID_MODEL, "--u", "u=1"], "no inputs"),
    (["simulate", HYBRID_MODEL, "--steps", "5"], "--steps"),
    (["simulate", PWA_MODEL, "--steps", "0"], "--steps"),
    (["simulate", PWA_MODEL, "--steps", "1000000000000"], "MAX_SAMPLES"),
    (["simulate", PWA_MODEL, "--q0", "5"], "--q0"),
    (["simulate", PWA_MODEL, "--ts", "0.1"], "--ts"),
    (["simulate", PWA_MODEL, "--t-final", "1"], "--steps"),
    (["simulate", PWA_MODEL, "--u", "u=1e300"], "--x0 / --u"),
    (["simulate", NONLINEAR_MODEL, "--ts", "1e-15", "--t-final", "10"], "MAX_SAMPLES"),
    (["simulate", NONLINEAR_MODEL, "--q0", "1"], "--q0"),
    # regions
    (["regions", "powertrain3", "-T", "0"], "--horizon"),
    (["regions", "powertrain3", "-T", "2"], "eq. 8"),
    (["regions", "driveline", "-T", "3"], "--ts"),
    (["regions", "driveline", "-T", "3", "--ts", "0"], "--ts"),
    (["regions", "driveline", "-T", "3", "--ts", "inf"], "--ts"),
    (["regions", "powertrain3", "-T", "3", "--ts", "0.1"], "--ts"),
    (["regions", "vehicle_tracking", "-T", "3"], "PWA"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=abc"], "--cut theta"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=nan"], "--cut theta"),
    (["regions", "powertrain3", "-T", "3", "--cut", "nosuch=1"], "omega_m"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0", "--cut", "omega_m=1"], "exactly 1"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0", "--resolution", "0x0"], "--resolution"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0", "--resolution", "abc"], "NXxNY"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0", "--resolution", "100000x100000"], "MAX_GRID_POINTS"),
    (["regions", "powertrain3", "-T", "3", "--resolution", "41x31"], "--cut or --plot"),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0", "--plot", "{dir}/c.xyz"], ".svg"),
    (["regions", "powertrain3", "-T", "3", "--plot", "{dir}/c.png"], "--cut"),
    (["regions", "powertrain3", "-T", "3", "--out", "{dir}"], "--out"),
    (["regions", "powertrain3", "-T", "3", "--query", "{nosuch.csv}"], "--query"),
    (["regions", "powertrain3", "-T", "3", "--query", "{empty.csv}"], "header"),
    (["regions", "powertrain3", "-T", "3", "--query", "{header_only.csv}"], "omega_l"),
    (["regions", "powertrain3", "-T", "3", "--query", "{dir}"], "--query"),
    (["regions", "powertrain3", "-T", "3", "--workers", "0"], "--workers"),
    (["regions", "powertrain3", "-T", "3", "--workers", "100000"], "MAX_WORKERS_PER_CORE"),
    (["regions", "powertrain3", "-T", "3", "--workers", "2", "--executor", "serial"], "--workers"),
    (["regions", "powertrain3", "-T", "3", "--dask-local", "0"], "--dask-local"),
    (["regions", "powertrain3", "-T", "3", "--dask-local", "100000"], "MAX_WORKERS_PER_CORE"),
    (["regions", "powertrain3", "-T", "3", "--scheduler", "foo://h:1"], "tcp, tls"),
    (["regions", "powertrain3", "-T", "3", "--scheduler", "tcp://h:0"], "65535"),
    (["regions", "powertrain3", "-T", "3", "--scheduler", "tcp://127.0.0.1:1", "--dask-local", "2"], "either"),
    (["regions", "powertrain3", "-T", "3", "--scheduler", "tcp://127.0.0.1:1", "--executor", "serial"], "--executor"),
    # observe
    (["observe", "traffic_light"], "one of"),
    (["observe", "triangular", "--observers", "nosuch"], "sliding-mode"),
    (["observe", "traffic_junction", "--observers", "nosuch"], "positive-deadbeat+projection"),
    (["observe", "switching_server", "--observers", "paper"], "deadbeat"),
    (["observe", "vehicle_tracking", "--observers", "nosuch"], "switched, single"),
    (["observe", "driveline", "--filter"], "--filter"),
    (["observe", "powertrain3", "--filter"], "sliding-mode"),
    (["observe", "vehicle_tracking", "--filter"], "--filter"),
    (["observe", "powertrain3", "--param", "gear_ratio=0.1"], "--param"),
    (["observe", "driveline", "--plot", "{dir}/o.xyz"], "--plot"),
    (["observe", "powertrain3", "--horizon", "3"], "--data"),
    (["observe", "powertrain3", "--regions", "{nosuch.json}"], "--data"),
    (["observe", HYBRID_MODEL], "--data"),
    (["observe", PWA_MODEL, "--data", "{nosuch.csv}"], "readable CSV"),
    (["observe", PWA_MODEL, "--data", "{bin.csv}"], "UnicodeDecodeError"),
    (["observe", PWA_MODEL, "--data", "{empty.csv}"], "empty file"),
    (["observe", PWA_MODEL, "--data", "{piston.csv}"], "missing"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--observers", "nosuch"], "milp_inf"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--horizon", "0"], "--horizon"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--horizon", "1000000"], "MAX_HORIZON"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--regions", "{bin.json}"], "regions file"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--regions", "{not_gains.json}"], "regions file"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--gains", "{not_gains.json}"], "--gains"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--filter"], "--filter"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--plot", "{dir}/o.xyz"], "--plot"),
    (["observe", PWA_MODEL, "--data", "{pwa.csv}", "--out", "{dir}"], "--out"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--observers", "nosuch"], "switched"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--gains", "{bin.json}"], "--gains"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--gains", "{empty.json}"], "--gains"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--gains", "{not_gains.json}"], "gains"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--horizon", "3"], "--horizon"),
    (["observe", "magnetic_piston", "--data", "{piston.csv}", "--filter"], "sliding-mode"),
    (["observe", "driveline", "--data", "{pwa.csv}"], "pwa"),
    # bench
    (["bench", "powertrain3", "--seed", "3"], "--noise"),
    (["bench", "powertrain3", "--observers", ",,"], "at least one"),
    (["bench", "powertrain3", "--observers", "lookup,,milp"], "empty name"),
    (["bench", "powertrain3", "--observers", "nosuch"], "milp_inf"),
    (["bench", "powertrain3", "--observers", "lookup,lookup"], "twice"),
    (["bench", "powertrain3", "--mhe-steps", "0"], "--mhe-steps"),
    (["bench", "powertrain3", "--mhe-steps", "5", "--observers", "lookup"], "moving-horizon"),
    (["bench", "powertrain3", "--steps", "2"], "--steps"),
    (["bench", "powertrain3", "--noise", "-1"], "--noise"),
    (["bench", "powertrain3", "--noise", "nan"], "--noise"),
    (["bench", "powertrain3", "--horizon", "0"], "--horizon"),
    (["bench", "powertrain3", "--horizon", "1000000"], "MAX_HORIZON"),
    (["bench", "powertrain3", "--plot", "{dir}/b.xyz"], "--plot"),
    (["bench", "powertrain3", "--regions", "{nosuch.json}"], "--regions"),
    (["bench", "driveline"], "--data"),
    (["bench", PWA_MODEL, "--data", "{pwa.csv}", "--steps", "10"], "--steps"),
    (["bench", PWA_MODEL, "--data", "{pwa.csv}", "--seed", "3"], "--seed"),
    (["bench", PWA_MODEL, "--data", "{pwa.csv}", "--noise", "0.1"], "--noise"),
    (["bench", PWA_MODEL, "--data", "{pwa.csv}", "--horizon", "1"], "eq. 8"),
    (["bench", PWA_MODEL, "--data", "{nosuch.csv}"], "readable CSV"),
    (["bench", "magnetic_piston", "--data", "{piston.csv}"], "pwa"),
    # export
    (["export", "powertrain3"], "--out-dir"),
    (["export", "nosuch", "--out-dir", "{dir}/c"], "SYSTEM"),
    (["export", "vehicle_tracking", "--out-dir", "{dir}/c"], "a PWA system"),
    (["export", HYBRID_MODEL, "--out-dir", "{dir}/c"], "a PWA system"),
    (["export", "powertrain3", "-T", "0", "--out-dir", "{dir}/c"], "--horizon"),
    (["export", "powertrain3", "-T", "1000000", "--out-dir", "{dir}/c"], "MAX_HORIZON"),
    (["export", "powertrain3", "-T", "2", "--out-dir", "{dir}/c"], "eq. 8"),
    (["export", "powertrain3", "--out-dir", "{a_file}"], "--out-dir"),
    (["export", "powertrain3", "--out", "{a_file}"], "--out-dir"),  # --out is the same option
    (["export", "powertrain3", "--out-dir", "{dir}/c", "--max-bytes", "0"], "--max-bytes"),
    (["export", "powertrain3", "--out-dir", "{dir}/c", "--max-ops", "-5"], "--max-ops"),
    (["export", "powertrain3", "--out-dir", "{dir}/c", "--max-ops", "1.5"], "invalid int value"),
    (["export", "powertrain3", "--out-dir", "{dir}/c", "--float32", "yes"], "unrecognized arguments"),
    (["export", "powertrain3", "--out-dir", "{dir}/c", "--param", "gear_ratio=abc"], "--param gear_ratio"),
    # report
    (["report", "--out-dir", "{dir}/rep", "--section", ""], "sliding_mode"),
    (["report", "--out-dir", "{dir}/rep", "--horizon", "3"], "SYSTEM"),
    (["report", "--out-dir", "{dir}/rep", "--data", "{pwa.csv}"], "SYSTEM"),
    (["report", "--out-dir", "{dir}/rep", "--param", "gear_ratio=2"], "SYSTEM"),
    (["report", "--out", "{a_file}", "--section", "examples"], "--out"),
    (["report", "powertrain3", "--out-dir", "{dir}/rep", "--section", "examples"], "--section"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--horizon", "0"], "--horizon"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--horizon", "1000000"], "MAX_HORIZON"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--horizon", "1"], "eq. 8"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--data", "{bin.csv}"], "readable CSV"),
    (["report", HYBRID_MODEL, "--out-dir", "{dir}/rep", "--data", "{pwa.csv}"], "--data"),
    (["report", HYBRID_MODEL, "--out-dir", "{dir}/rep", "--horizon", "5"], "--horizon"),
    (["report", "--out-dir", "{dir}/rep", "--noise-bound", "0.1"], "SYSTEM"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--noise-bound", "0.1"], "--data"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--data", "{pwa.csv}", "--noise-bound", "z=0.1"], "'z'"),
    (["report", PWA_MODEL, "--out-dir", "{dir}/rep", "--data", "{pwa.csv}", "--noise-bound", "-1"], "--noise-bound"),
    (["report", HYBRID_MODEL, "--out-dir", "{dir}/rep", "--noise-bound", "0.1"], "--noise-bound"),
    (["report", "nosuch", "--out-dir", "{dir}/rep"], "SYSTEM"),
    # diagnose and synth
    (["diagnose", "powertrain3"], "scalar-nonlinear"),
    (["diagnose", HYBRID_MODEL], "scalar-nonlinear"),
    (["diagnose", "vehicle_tracking", "--range", "psi=abc"], "NAME=LO:HI"),
    (["diagnose", "vehicle_tracking", "--range", "psi=10:5"], "LO < HI"),
    (["diagnose", "vehicle_tracking", "--range", "psi=nan:5"], "finite"),
    (["diagnose", "vehicle_tracking", "--range", "psi=0:inf"], "finite"),
    (["diagnose", "vehicle_tracking", "--range", "nosuch=0:1"], "delta_f"),
    (["diagnose", "vehicle_tracking", "--range", "X=0:1"], "'psi'"),
    (["diagnose", "vehicle_tracking", "--range", "psi=0:1e300"], "[0, 360] deg"),
    (["diagnose", "vehicle_tracking", "--range", "psi=-10:100"], "[0, 360] deg"),
    (["diagnose", "magnetic_piston", "--range", "z=-10:203"], "[0, 203] mm"),
    (["diagnose", "vehicle_tracking", "--gain-bound", "5"], "--settings model"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--gain-bound", "-1"], "--gain-bound"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--gain-bound", "nan"], "--gain-bound"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--min-decay", "0"], "--min-decay"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--min-decay", "1e300"], "sigma_cap"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--overlap", "-1"], "--overlap"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--overlap", "1e300"], "--overlap"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--coordinate", "nosuch"], "delta_f"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--range", "psi=0:1deg"], "model units"),
    (["diagnose", "vehicle_tracking", "--settings", "model", "--range", "psi=0:7"], "[0, 6.28319]"),
    (["diagnose", "vehicle_tracking", "--out", "{a_file}"], "--out"),
    (["diagnose", "vehicle_tracking", "--param", "V=abc"], "--param V"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--max-rate", "-1"], "--max-rate"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--max-rate", "inf"], "--max-rate"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--periodic", "psi=0"], "--periodic"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--periodic", "nosuch=1"], "delta_f"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--periodic", "psi=6.28", "--periodic", "psi=6.28"], "twice"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--periodic", "psi=6.28", "--no-verify"], "--no-verify"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--range", "psi=5:1"], "LO < HI"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--range", "psi=0:400"], "[0, 360] deg"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--coordinate", "psi"], "--settings model"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--settings", "model", "--min-decay", "-1"], "--min-decay"),
    (["synth", "vehicle_tracking", "--out", "{dir}", "--no-verify"], "--out"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--noise-bound", "-1"], "--noise-bound"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--noise-bound", "abc"], "--noise-bound"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--noise-bound", "nosuch=1"], "--noise-bound"),
    (["synth", "vehicle_tracking", "--out", "{dir}/g.json", "--noise-bound", "Y_meas=nan"], "--noise-bound"),
    (["synth", "powertrain3", "--out", "{dir}/g.json"], "scalar-nonlinear"),
    # model
    (["model", "check"], "SYSTEM"),
    (["model", "check", "nosuch"], "SYSTEM"),
    (["model", "check", "{empty.toml}"], "class"),
    (["model", "check", "powertrain3", "--param", "gear_ratio=1/0"], "--param gear_ratio"),
    (["model", "check", "powertrain3", "--out", "{dir}/x.toml"], "--out"),
    (["model", "export", "powertrain3"], "--out"),
    (["model", "export", "powertrain3", "--out", "{dir}/x.xyz"], ".toml"),
    (["model", "export", "powertrain3", "--out", "{dir}"], "--out"),
    (["model", "schema", "powertrain3"], "SYSTEM"),
    (["model", "schema", "--out", "{dir}/x.toml"], "--out"),
    (["model", "schema", "--param", "a=1"], "--param"),
]


def _fill(argv: list[str], files) -> list[str]:
    out = []
    for a in argv:
        if a.startswith("{") and "}" in a:
            key, rest = a[1:].split("}", 1)
            a = str(files[key] if key in files else files["dir"] / key) + rest
        out.append(a)
    return out


def _id(row) -> str:
    argv = [Path(a).name if "/" in a and "://" not in a else a for a in row[0]]
    return " ".join(argv)[:70]


@pytest.mark.parametrize("argv, fragment", CAMPAIGN, ids=[_id(r) for r in CAMPAIGN])
def test_campaign_one_line(capsys, files, argv, fragment):
    line = one_line_error(capsys, *_fill(argv, files))
    command = argv[0] if argv else ""
    assert line.startswith(f"hybobs {command}: error: " if command else "hybobs: error: "), line
    assert fragment in line, (fragment, line)


#: Every second row again under ``--json`` (each command and kind of error is among them; all rows
#: would double the file's run time for no new code path: the JSON form is printed by one function).
JSON_ROWS = CAMPAIGN[::2] + [r for r in CAMPAIGN[1::2] if r[0][0] == "examples"]


@pytest.mark.parametrize("argv, fragment", JSON_ROWS, ids=[_id(r) for r in JSON_ROWS])
def test_campaign_json(capsys, files, argv, fragment):
    record = json_error(capsys, *_fill(argv, files), "--json")
    assert record["command"] == argv[0]
    assert fragment in record["error"], (fragment, record)
