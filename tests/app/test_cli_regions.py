"""``hybobs regions``: the JSON fields, point queries from a CSV file, bad input (exit code 2)."""

import json

import pytest

from hybobs_opt.cli import main


def test_cli_regions_json_and_query(capsys, tmp_path):
    q = tmp_path / "q.csv"
    q.write_text("omega_l,theta,omega_m\n25,0.0,100\n25,0.15,100\n")
    code = main(["regions", "powertrain3", "--horizon", "3", "--json", "--executor", "serial", "--query", str(q)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    for key in ("n_regions", "n_full_rank", "n_unobservable_pieces", "n_lps", "seconds"):
        assert key in out
    assert out["observable"] == [False, True]  # inside the band / in contact


def test_cli_regions_query_tells_unobservable_from_infeasible(capsys, tmp_path):
    """``query`` gives each state's class: in the backlash band (unobservable), in contact
    (observable), and beyond the shaft-torsion bound |theta| <= 0.2 rad (infeasible, outside X*_T);
    ``observable`` stays true only for the observable one."""
    q = tmp_path / "q.csv"
    q.write_text("omega_l,theta,omega_m\n25,0.0,100\n25,0.15,100\n25,0.5,100\n")
    argv = ["regions", "powertrain3", "--horizon", "3", "--executor", "serial", "--query", str(q)]
    assert main(argv + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["query"] == ["unobservable", "observable", "infeasible"]
    assert out["observable"] == [False, True, False]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "query: 3 states: 1 observable, 1 unobservable, 1 infeasible" in text and "row 3: infeasible" in text


def test_cli_regions_pair_by_pair_gives_every_pair_its_own_verdict(capsys):
    """``--pair-by-pair``: the same pieces, nothing ruled out by a group, the full thin / same-state
    counts (those of ``analyse_observability(..., group_tests=False)``) and more LPs."""
    from hybobs_opt import get_example
    from hybobs_opt.regions import analyse_observability

    base = ["regions", "powertrain3", "--horizon", "5", "--json", "--executor", "serial", "--no-cache"]
    assert main(base) == 0
    grouped = json.loads(capsys.readouterr().out)
    assert main(base + ["--pair-by-pair"]) == 0
    single = json.loads(capsys.readouterr().out)
    ref = analyse_observability(get_example("powertrain3").build(), 5, group_tests=False)
    assert single["n_unobservable_pieces"] == grouped["n_unobservable_pieces"] == ref.n_unobservable_pieces
    assert single["n_pairs_ruled_out_by_group"] == 0 < grouped["n_pairs_ruled_out_by_group"]
    assert single["n_pairs_dropped_thin"] == ref.stats["n_pairs_dropped_thin"] > grouped["n_pairs_dropped_thin"]
    assert single["n_pairs_dropped_same_state"] == ref.stats["n_pairs_dropped_same_state"]
    assert single["n_lps_pairs"] == ref.n_pair_lps > grouped["n_lps_pairs"]


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["regions", "powertrain3", "--horizon", "2"], "eq. 8"),
        (["regions", "traffic_junction", "--horizon", "3"], "PWA"),
        (["regions", "powertrain3", "--horizon", "3", "--cut", "speed=3"], "--cut"),
        (["regions", "powertrain3", "--horizon", "3", "--plot", "x.png"], "--cut"),
    ],
)
def test_cli_regions_bad_input(capsys, argv, fragment):
    assert main(argv) == 2
    assert fragment in capsys.readouterr().err
