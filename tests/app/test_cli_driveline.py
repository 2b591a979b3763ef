"""``hybobs observe driveline`` (paper 000): the output names the plant it ran."""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.studies.paper000_driveline.scenario import run_driveline
from hybobs_opt.studies.paper000_driveline.systems import driveline


@pytest.fixture(scope="module")
def fig6():
    return run_driveline()


def test_observe_driveline_names_the_plant_it_runs(fig6, monkeypatch):
    """`hybobs observe driveline` runs k = 1000 N m/rad while `driveline()` defaults to k = 0:
    the output says which plant it ran, and that plant is the one the scenario simulated."""
    import argparse

    from hybobs_opt.studies.paper000_driveline import scenario as driveline_study

    monkeypatch.setattr(driveline_study, "run_driveline", lambda: fig6)
    out = driveline_study.driveline_scenario(argparse.Namespace(plot=None, json=True))
    assert out["plant"] == "driveline" and out["plant_params"] == {"k": 1000.0}
    assert "k = 0" in out["plant_note"]
    named = driveline(**out["plant_params"])
    default = driveline()
    for q in range(3):
        np.testing.assert_array_equal(fig6.automaton.locations[q].A, named.locations[q].A)
    assert not np.array_equal(fig6.automaton.locations[1].A, default.locations[1].A)
