"""The pair-LP budget of Algorithm 3.1 (``analyse_observability(..., max_pair_lps=)``) at small
horizons, where the prediction counts the regions at ``T`` itself: the enumeration runs once, and
the budget still refuses the analysis before any pair LP."""

from __future__ import annotations

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.regions import analyse_observability, enumerate_modes
from hybobs_opt.regions import enumeration as enumeration_module
from hybobs_opt.regions import observability as observability_module
from hybobs_opt.regions.enumeration import PAIR_LPS_PER_REGION_POWER, counted_exactly, predict_analysis_cost
from hybobs_opt.studies.paper002_powertrain.systems import powertrain3


def test_small_horizons_are_counted_exactly_and_larger_ones_extrapolated():
    plant = powertrain3()  # n = 3, p = 1: eq. (8) needs T >= 3
    assert [counted_exactly(plant, T) for T in (3, 4, 5, 6)] == [True, True, True, False]
    enum = enumerate_modes(plant, 4)
    pred = predict_analysis_cost(plant, 4, enumeration=enum)
    assert pred == predict_analysis_cost(plant, 4)
    assert pred["regions"] == len(enum.regions) and pred["basis"] == [4]
    assert pred["pair_lps"] == pytest.approx(PAIR_LPS_PER_REGION_POWER * len(enum.regions) ** 1.5)
    assert predict_analysis_cost(plant, 7)["basis"] == [4, 5]


def test_an_enumeration_of_another_horizon_or_system_is_refused():
    plant = powertrain3()
    with pytest.raises(ModelError, match="enumeration"):
        predict_analysis_cost(plant, 4, enumeration=enumerate_modes(plant, 3))
    with pytest.raises(ModelError, match="another system"):
        predict_analysis_cost(plant, 4, enumeration=enumerate_modes(powertrain3(), 4))


def test_the_analysis_enumerates_once_at_a_small_horizon(monkeypatch):
    calls = []
    real = enumeration_module.enumerate_modes

    def counting(system, T, **kw):
        calls.append(T)
        return real(system, T, **kw)

    monkeypatch.setattr(enumeration_module, "enumerate_modes", counting)
    monkeypatch.setattr(observability_module, "enumerate_modes", counting)
    analyse_observability(powertrain3(), 4)
    assert calls == [4]
    calls.clear()
    analyse_observability(powertrain3(), 6)
    assert calls == [4, 5, 6]  # the prediction's two counts, then the analysis


def test_the_budget_refuses_a_small_horizon_before_any_pair_lp(monkeypatch):
    def no_pairs(*a, **kw):
        raise AssertionError("a pair test ran")

    monkeypatch.setattr(observability_module, "_pairs_task", no_pairs)
    n = len(enumerate_modes(powertrain3(), 4).regions)
    needed = PAIR_LPS_PER_REGION_POWER * n ** 1.5
    with pytest.raises(ModelError, match="max_pair_lps") as err:
        analyse_observability(powertrain3(), 4, max_pair_lps=int(needed) - 1)
    assert "counted at T = [4]" in str(err.value)


@pytest.mark.parametrize("bad", [0, -5, 2.5, True, "many"])
def test_a_bad_budget_is_refused_before_the_enumeration(monkeypatch, bad):
    def no_enumeration(*a, **kw):
        raise AssertionError("the enumeration ran")

    monkeypatch.setattr(observability_module, "enumerate_modes", no_enumeration)
    monkeypatch.setattr(enumeration_module, "enumerate_modes", no_enumeration)
    with pytest.raises(ModelError, match="max_pair_lps"):
        analyse_observability(powertrain3(), 4, max_pair_lps=bad)
