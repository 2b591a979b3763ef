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
