"""``hybobs observe traffic_junction`` / ``switching_server`` (paper 003): the JSON fields."""

from __future__ import annotations

import argparse
import json

import pytest

from hybobs_opt.errors import ModelError


def test_observe_json_scenario(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "traffic_junction", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    evs = out["visible_events"]
    assert [round(e["t"], 1) for e in evs[:3]] == [70.7, 79.2, 140.3]
    assert [round(evs[k]["predicted_t"], 1) for k in (0, 2)] == [81.7, 137.0]
    for e in evs:
        assert set(("t", "predicted_t", "x_before", "x_after")) <= set(e) and len(e["x_after"]) == 4
    assert max(abs(v) for v in out["final_error"]) < 1e-9
    assert main(["observe", "switching_server", "--json", "--observers", "positive+projection"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["observer"] == "positive+projection" and out["nonnegative"]
    from hybobs_opt.studies.scenarios import get_scenario

    with pytest.raises(ModelError):
        get_scenario("switching_server")(argparse.Namespace(observer="paper", plot=None, json=True))
