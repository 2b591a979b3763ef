"""``hybobs observe`` on the sliding-mode examples of paper 001: the JSON fields."""

import json

import pytest


def test_cli_switched_unstable_json(capsys):
    """Example 1 through ``hybobs observe``: both stages converge while the plant's state grows
    4-fold per revolution (Remark 1: the bounded-state assumption concerns the switched system)."""
    from hybobs_opt.cli import main

    assert main(["observe", "switched_unstable", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["example"] == "switched_unstable"
    times = [c["t"] for c in out["convergence_times"]]
    assert [c["state"] for c in out["convergence_times"]] == ["z1", "z2"]
    assert all(t is not None and t < 1.0 for t in times)
    Ts = out["Ts"]
    # error band j h D_j with |z2| <= 100 and |z2'| <= 400 on the operating box (see the test above)
    assert out["final_error_band"]["z1"] <= 1 * Ts * 100.0 * 1.01
    assert out["final_error_band"]["z2"] <= 2 * Ts * 400.0 * 1.01


def test_cli_double_scroll_json_with_filter(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "double_scroll", "--json", "--filter"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [c["state"] for c in out["convergence_times"]] == ["z1", "z2", "z3"]
    times = [c["t"] for c in out["convergence_times"]]
    assert all(t is not None for t in times) and times == sorted(times)
    assert set(out["final_error_band"]) == {"z1", "z2", "z3"}
    assert 0 <= out["indicator_mismatch_fraction"] < 0.01
    f = out["filtered"]
    assert f["filter_tau"] > 0 and {"convergence_times", "final_error_band", "indicator_mismatch_fraction"} <= set(f)


@pytest.mark.slow
def test_cli_triangular_json(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "triangular", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [c["state"] for c in out["convergence_times"]] == ["x1", "x2", "x3"]
    assert out["indicator_mismatch_fraction"] < 0.01 and "filtered" not in out
