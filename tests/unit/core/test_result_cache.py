"""The cache of analyses and lookup tables (issue 17, :mod:`hybobs_opt.cache`): a hit gives the
answer a fresh computation gives, every damaged entry is refused and recomputed, and the key
separates what must not be shared (another system, another horizon, another code)."""

from __future__ import annotations

import numpy as np
import pytest

import hybobs_opt.cache as cache_module
from hybobs_opt.cache import ResultCache, active_cache, cached_analysis, use_cache
from hybobs_opt.errors import ModelError
from hybobs_opt.observers.comparison import exact_window_labels
from hybobs_opt.observers.lookup import LookupObserver
from hybobs_opt.regions import analyse_observability
from hybobs_opt.studies import get_example


@pytest.fixture(scope="module")
def plant():
    return get_example("powertrain3").build()


@pytest.fixture(scope="module")
def fresh(plant):
    return analyse_observability(plant, 3)


@pytest.fixture(scope="module")
def scenario(plant):
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario

    return backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=3000 * plant.Ts)


def _outcomes(cache):
    return [(e["kind"], e["outcome"]) for e in cache.events]


def test_no_active_cache_by_default_and_nothing_written(tmp_path, plant):
    assert active_cache() is None
    cached_analysis(plant, 3)
    assert not any(tmp_path.iterdir())


def test_a_hit_is_the_analysis_a_fresh_run_computes(tmp_path, plant, fresh):
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        first = cached_analysis(plant, 3)
        second = cached_analysis(plant, 3)
    assert _outcomes(cache) == [("analysis", "stored"), ("analysis", "hit")]
    for a in (first, second):
        assert a.index_set == fresh.index_set
        assert [r.sequence for r in a.regions] == [r.sequence for r in fresh.regions]
        assert [(p.i, p.j) for p in a.pairs] == [(p.i, p.j) for p in fresh.pairs]
    # the same verdicts on states (points of every label of the analysis computed afresh)
    rng = np.random.default_rng(0)
    lo, hi = plant.state_bounds.bounding_box()
    X = rng.uniform(lo, hi, size=(40, plant.n))
    assert [second.classify(x) for x in X] == [fresh.classify(x) for x in X]
    assert active_cache() is None  # the block restored the previous (none)


@pytest.mark.parametrize("damage", ["truncate", "garbage", "edit"])
def test_a_damaged_analysis_entry_is_refused_and_recomputed(tmp_path, plant, fresh, damage):
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        cached_analysis(plant, 3)
    (entry,) = tmp_path.glob("analysis-*.json")
    text = entry.read_text()
    entry.write_text({"truncate": text[: len(text) // 2], "garbage": "\x00not json",
                      "edit": text.replace('"full_rank": [', '"full_rank": [true, ', 1)}[damage])
    with use_cache(cache):
        again = cached_analysis(plant, 3)
    assert _outcomes(cache)[-1] == ("analysis", "refused")
    assert "reason" in cache.events[-1]
    assert again.index_set == fresh.index_set
    with use_cache(cache):  # rewritten: the next run hits
        cached_analysis(plant, 3)
    assert _outcomes(cache)[-1] == ("analysis", "hit")


def test_the_key_separates_systems_horizons_and_code(tmp_path, plant, monkeypatch):
    cache = ResultCache(tmp_path)
    other = get_example("powertrain3").build(gear_ratio=0.5)
    with use_cache(cache):
        cached_analysis(plant, 3)
        cached_analysis(other, 3)  # another system (another fingerprint)
        cached_analysis(plant, 4)  # another horizon
        monkeypatch.setattr(cache_module, "code_digest", lambda: "an edited checkout")
        cached_analysis(plant, 3)  # another code
    assert [o for _, o in _outcomes(cache)] == ["stored"] * 4
    assert len(list(tmp_path.glob("analysis-*.json"))) == 4


def test_lookup_tables_from_the_cache_run_as_the_fresh_ones(tmp_path, fresh, scenario):
    U, Y = scenario.u, scenario.y
    reference = LookupObserver(fresh).run(U, Y)
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        stored = LookupObserver(fresh)
        loaded = LookupObserver(fresh)
    assert _outcomes(cache) == [("lookup-pieces", "stored"), ("lookup-pieces", "hit")]
    for obs in (stored, loaded):
        out = obs.run(U, Y)
        np.testing.assert_array_equal(out.flags, reference.flags)
        np.testing.assert_array_equal(out.mode, reference.mode)
        np.testing.assert_allclose(out.x_hat, reference.x_hat, rtol=0, atol=1e-12)
    assert loaded.stats()["n_btilde_pieces"] == LookupObserver(fresh).stats()["n_btilde_pieces"]


def test_a_corrupted_table_entry_is_refused(tmp_path, fresh, scenario):
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        LookupObserver(fresh)
    (entry,) = tmp_path.glob("lookup-pieces-*.npz")
    data = dict(np.load(entry))
    data["lp_b0"] = data["lp_b0"] + 1.0  # the arrays no longer match their SHA-256
    np.savez_compressed(entry, **data)
    with use_cache(cache):
        obs = LookupObserver(fresh)
    assert _outcomes(cache)[-1] == ("lookup-pieces", "refused")
    assert "MAC" in cache.events[-1]["reason"]  # rewritten without the key: not the toolbox's entry
    ref = LookupObserver(fresh).run(scenario.u, scenario.y)
    np.testing.assert_array_equal(obs.run(scenario.u, scenario.y).flags, ref.flags)
    entry.write_bytes(b"PK\x03\x04 not a zip")
    with use_cache(cache):
        LookupObserver(fresh)
    assert _outcomes(cache)[-1] == ("lookup-pieces", "refused")


def test_exact_labels_through_the_cache(tmp_path, fresh, scenario):
    ends, labels = exact_window_labels(fresh, scenario.x, samples=60)
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        a = exact_window_labels(fresh, scenario.x, samples=60)
        b = exact_window_labels(fresh, scenario.x, samples=60)
        exact_window_labels(fresh, scenario.x[1:].copy(), samples=60)  # other states: another key
    assert _outcomes(cache) == [("exact-labels", "stored"), ("exact-labels", "hit"), ("exact-labels", "stored")]
    for got_ends, got in (a, b):
        np.testing.assert_array_equal(got_ends, ends)
        assert list(got) == list(labels)
    assert set(labels) <= {"observable", "unobservable", "infeasible"} and "observable" in set(labels)


def test_an_unwritable_directory_runs_without_caching(tmp_path, plant, fresh):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    messages = []
    cache = ResultCache(blocker / "cache", log=messages.append)  # under a regular file: cannot be created
    with use_cache(cache):
        a = cached_analysis(plant, 3)
        cached_analysis(plant, 3)
    assert [o for _, o in _outcomes(cache)] == ["not stored", "not stored"]
    assert a.index_set == fresh.index_set
    assert sum("is not writable" in m for m in messages) == 1  # the directory said once


def test_entries_and_clear(tmp_path, plant, fresh):
    cache = ResultCache(tmp_path / "c")
    assert cache.entries() == [] and cache.clear() == (0, 0)
    with use_cache(cache):
        cached_analysis(plant, 3)
        LookupObserver(fresh)
    kinds = sorted(e["kind"] for e in cache.entries())
    assert kinds == ["analysis", "lookup-pieces"]
    size = sum(e["bytes"] for e in cache.entries())
    files, removed = cache.clear()  # the two entries and their two MACs
    assert files == 4 and removed > size and cache.entries() == []


def test_bad_arguments():
    with pytest.raises(ModelError, match="cache"):
        with use_cache("a directory"):
            pass
    with pytest.raises(ModelError, match="log"):
        ResultCache(log="stderr")
    with pytest.raises(ModelError, match="horizon T"):
        with use_cache(ResultCache()):
            cached_analysis(get_example("powertrain3").build(), 0)


def test_default_directory(monkeypatch, tmp_path):
    monkeypatch.setenv("HYBOBS_CACHE_DIR", str(tmp_path / "x"))
    assert cache_module.default_cache_dir() == tmp_path / "x"
    monkeypatch.delenv("HYBOBS_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_module.default_cache_dir() == tmp_path / "xdg" / "hybobs_opt"
