"""MHESettings: the solve and certification settings of MHEObserver, validated once.

The fields of :class:`~hybobs_opt.mhe.MHESettings` were keywords of ``MHEObserver``; each old
keyword still works for one release with exactly one ``FutureWarning`` and gives the same settings
as the new spelling, any other unknown keyword is a ``ModelError`` naming it, and
``observer.settings`` states the settings in force.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import warnings

import pytest

from hybobs_opt import defaults, tolerances
from hybobs_opt.errors import ModelError
from hybobs_opt.mhe import MHEObserver, MHESettings, big_m_constants
from hybobs_opt.defaults import MHE_PROX_PASSES
from hybobs_opt.studies.registry import get_example

#: A valid value other than the default, per field.
CHANGED = {
    "solver_options": {"cycle_tol": 500},
    "polish": False,
    "prox_weight": 1e-9,
    "binary_prox_weight": 1e-9,
    "zero_cost_certificate": False,
    "prox_passes": 2,
    "certify_max_nodes": 100,
    "certify_time_budget": 5.0,
    "check_uniqueness": False,
    "uniqueness_delta": 0.1,
}

#: Values each validated field refuses.
INVALID = [
    ("solver_options", "x"), ("solver_options", [1]),
    ("prox_weight", 0.0), ("prox_weight", True), ("prox_weight", "1"), ("prox_weight", math.nan),
    ("binary_prox_weight", 0.0), ("binary_prox_weight", 1j), ("binary_prox_weight", -1.0),
    ("prox_passes", 0), ("prox_passes", 1.5), ("prox_passes", True),
    ("certify_max_nodes", 0), ("certify_max_nodes", 2.0), ("certify_max_nodes", False),
    ("certify_time_budget", 0), ("certify_time_budget", -1.0), ("certify_time_budget", math.inf),
    ("certify_time_budget", "1"),
    ("check_uniqueness", "yes"), ("check_uniqueness", 1), ("check_uniqueness", None),
    ("uniqueness_delta", 0.0), ("uniqueness_delta", math.nan), ("uniqueness_delta", True), ("uniqueness_delta", "0.1"),
]


@pytest.fixture(scope="module")
def plant():
    return get_example("powertrain3").build()


@pytest.fixture(scope="module")
def big_m(plant):
    return big_m_constants(plant)


def test_every_field_has_a_changed_value_and_an_invalid_one():
    names = {f.name for f in dataclasses.fields(MHESettings)}
    assert set(CHANGED) == names
    assert {field for field, _ in INVALID} == names - {"polish", "zero_cost_certificate"}


def test_the_defaults_are_the_named_values(plant, big_m):
    s = MHESettings()
    assert s == MHESettings(solver_options=None)
    assert (s.prox_weight, s.binary_prox_weight, s.certify_max_nodes, s.uniqueness_delta) == (
        tolerances.MHE_PROX_WEIGHT, tolerances.MHE_BINARY_PROX_WEIGHT, defaults.MHE_CERTIFY_MAX_NODES,
        defaults.MHE_UNIQUENESS_DELTA)
    assert (s.solver_options, s.polish, s.zero_cost_certificate, s.prox_passes, s.certify_time_budget,
            s.check_uniqueness) == ({}, True, True, MHE_PROX_PASSES, None, True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        assert MHEObserver(plant, 3, big_m=big_m).settings == s


@pytest.mark.parametrize("field", sorted(CHANGED))
def test_an_old_keyword_warns_once_and_gives_the_new_settings(plant, big_m, field):
    value = CHANGED[field]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = MHEObserver(plant, 3, big_m=big_m, **{field: value})
    future = [w for w in caught if issubclass(w.category, FutureWarning)]
    assert len(future) == 1, [str(w.message) for w in caught]
    assert re.fullmatch(rf"MHEObserver\({field}=\.\.\.\) is deprecated and goes in hybobs_opt 0\.2\.0: use "
                        rf"MHEObserver\(settings=MHESettings\({field}=\.\.\.\)\)", str(future[0].message))
    assert future[0].filename == __file__  # the caller's line
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        new = MHEObserver(plant, 3, big_m=big_m, settings=MHESettings(**{field: value}))
    assert old.settings == new.settings
    assert getattr(new.settings, field) == value


def test_several_old_keywords_warn_once_each(plant, big_m):
    with pytest.warns(FutureWarning) as record:
        obs = MHEObserver(plant, 3, big_m=big_m, check_uniqueness=False, prox_passes=2)
    assert sorted(re.match(r"MHEObserver\((\w+)=", str(w.message)).group(1) for w in record) == [
        "check_uniqueness", "prox_passes"]
    assert obs.settings == MHESettings(check_uniqueness=False, prox_passes=2)


def test_an_unknown_keyword_is_a_model_error_naming_it(plant, big_m):
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        with pytest.raises(ModelError, match="chek_uniqueness") as err:
            MHEObserver(plant, 3, big_m=big_m, chek_uniqueness=False)
    assert err.value.field == "MHEObserver(chek_uniqueness=...)"
    assert "settings=MHESettings(check_uniqueness=...)" in str(err.value)  # the likely intent
    with pytest.raises(ModelError, match="nosuch"):
        MHEObserver(plant, 3, big_m=big_m, nosuch=1)


def test_settings_and_an_old_keyword_together_are_refused(plant, big_m):
    with pytest.raises(ModelError) as err, pytest.warns(FutureWarning):
        MHEObserver(plant, 3, big_m=big_m, settings=MHESettings(), check_uniqueness=False)
    assert err.value.field == "settings"


@pytest.mark.parametrize("bad", [{"check_uniqueness": False}, "default", 5])
def test_settings_must_be_an_mhe_settings(plant, big_m, bad):
    with pytest.raises(ModelError) as err:
        MHEObserver(plant, 3, big_m=big_m, settings=bad)
    assert err.value.field == "settings"


@pytest.mark.parametrize("field, bad", INVALID, ids=[f"{f}-{b!r}" for f, b in INVALID])
def test_an_invalid_value_is_a_model_error_naming_the_field(field, bad):
    with pytest.raises(ModelError) as err:
        MHESettings(**{field: bad})
    assert err.value.field == field
    with pytest.raises(ModelError) as err:
        dataclasses.replace(MHESettings(), **{field: bad})  # a changed copy is checked again
    assert err.value.field == field


def test_an_invalid_old_keyword_is_the_same_model_error(plant, big_m):
    with pytest.raises(ModelError) as err, pytest.warns(FutureWarning):
        MHEObserver(plant, 3, big_m=big_m, prox_passes=0)
    assert err.value.field == "prox_passes"


def test_values_are_normalised_and_the_record_frozen():
    options = {"iter_limit": 7}
    s = MHESettings(solver_options=options, polish=0, prox_passes=True + 1, uniqueness_delta=1)
    options["iter_limit"] = 8  # the settings hold a copy
    assert s.solver_options == {"iter_limit": 7}
    assert s.polish is False and type(s.prox_passes) is int and type(s.uniqueness_delta) is float
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.check_uniqueness = False


def test_to_dict_is_every_field_json_ready():
    s = MHESettings(**CHANGED)
    d = s.to_dict()
    assert list(d) == [f.name for f in dataclasses.fields(MHESettings)]
    assert d == CHANGED and MHESettings(**d) == s
    assert json.loads(json.dumps(d)) == d


def test_the_effective_settings_under_a_noise_bound_have_no_uniqueness_test(plant, big_m):
    asked = MHESettings(uniqueness_delta=0.1)
    obs = MHEObserver(plant, 3, big_m=big_m, noise_bound=1e-3, settings=asked)
    assert obs.settings == dataclasses.replace(asked, check_uniqueness=False)
    assert asked.check_uniqueness is True
    assert MHEObserver(plant, 3, big_m=big_m, noise_bound=1e-3).settings.check_uniqueness is False
