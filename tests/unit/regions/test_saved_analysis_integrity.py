"""A saved observability analysis cannot be applied to another system or loaded after an edit.

``save_analysis`` stores the system's model dictionary, its fingerprint (SHA-256 of the
canonical JSON of ``system.to_dict()``) and a checksum of the content; ``load_analysis``
refuses an edited file, a file computed for another plant (another gear ratio of powertrain3,
a rotation PWA system with angle pi/3 instead of pi/4) and a version-1 file (no checksum).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from canonical import rotation_pwa

from hybobs_opt.errors import ModelError
from hybobs_opt.executor import SerialExecutor
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.regions import analyse_observability, load_analysis, save_analysis
from hybobs_opt.regions.io import VERSION
from hybobs_opt.systems.saved_file import content_checksum
from hybobs_opt.studies.registry import get_example
from hybobs_opt.systems.fingerprint import canonical_json, first_difference, system_fingerprint
from hybobs_opt.systems.model_dict import system_from_dict

#: The entries of a version-1 file: users' scripts read them, so they stay.
V1_KEYS = {"format", "version", "example", "params", "system_name", "state_names", "horizon", "scale", "centre",
           "regions", "full_rank", "pairs", "enumeration_stats", "analysis_stats", "summary"}


rotation = rotation_pwa


@pytest.fixture(scope="module")
def pt3():
    plant = get_example("powertrain3").build()
    # T = 3: the smallest horizon powertrain3 admits (eq. 8 refuses T = 2).
    return plant, analyse_observability(plant, 3, executor=SerialExecutor())


@pytest.fixture()
def saved(pt3, tmp_path):
    return save_analysis(pt3[1], tmp_path / "pt3.json", "powertrain3", {})


def _box(poly: Polytope) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of a box polytope given by rows +-e_k."""
    n = poly.A.shape[1]
    lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
    for a, b in zip(poly.A, poly.b):
        k = int(np.argmax(np.abs(a)))
        assert np.count_nonzero(a) == 1 and abs(a[k]) == 1.0, "state bounds are expected to be a box"
        if a[k] > 0:
            hi[k] = min(hi[k], b)
        else:
            lo[k] = max(lo[k], -b)
    return lo, hi


def _rewrite(path, edit, *, fix_checksum: bool = False):
    data = json.loads(path.read_text())
    edit(data)
    if fix_checksum:
        data["checksum"] = content_checksum(data)
    path.write_text(json.dumps(data))
    return path


# ------------------------------------------------------------------ round trip

def test_round_trip_answers_identically_on_random_points(pt3, saved):
    plant, analysis = pt3
    data = json.loads(saved.read_text())  # still plain JSON
    assert V1_KEYS <= set(data) and data["version"] == VERSION == 2
    assert data["system_fingerprint"] == system_fingerprint(plant)
    assert data["system_model"] == json.loads(canonical_json(plant.to_dict()))
    loaded = load_analysis(saved)  # the system is rebuilt from the stored model
    assert system_fingerprint(loaded.system) == system_fingerprint(plant)
    also = load_analysis(saved, system=get_example("powertrain3").build())  # the same plant, built again
    lo, hi = _box(plant.state_bounds)
    X = np.random.default_rng(20240601).uniform(lo, hi, size=(200, plant.n))
    want = [analysis.is_observable(x) for x in X]
    assert [loaded.is_observable(x) for x in X] == want
    assert [also.is_observable(x) for x in X] == want
    assert any(want) and not all(want)  # both answers occur, so the comparison means something


def test_fingerprint_is_exact_and_survives_the_model_round_trip():
    a, b = rotation(math.pi / 3), rotation(math.pi / 4)
    assert system_fingerprint(a) == system_fingerprint(rotation(math.pi / 3))
    assert system_fingerprint(system_from_dict(a.to_dict())) == system_fingerprint(a)
    assert len(system_fingerprint(a)) == 64 and system_fingerprint(a) != system_fingerprint(b)
    assert first_difference(a.to_dict(), b.to_dict()) == "modes[0].A"
    assert first_difference(a.to_dict(), a.to_dict()) is None


# ------------------------------------------------------------------ another system

def test_refused_for_powertrain3_with_another_gear_ratio(saved):
    tau = get_example("powertrain3").params["gear_ratio"]
    other = get_example("powertrain3").build(gear_ratio=1.1 * tau)
    with pytest.raises(ModelError, match="computed for another system") as err:
        load_analysis(saved, system=other)
    msg = str(err.value)
    assert str(saved) in msg and other.name in msg and get_example("powertrain3").build().name in msg
    assert "first differing entry of the model dictionaries: modes[" in msg


def test_refused_for_rotation_with_another_angle(tmp_path):
    a = analyse_observability(rotation(math.pi / 3), 3, executor=SerialExecutor())
    path = save_analysis(a, tmp_path / "rot.json")
    assert load_analysis(path).T == 3  # no example name: rebuilt from the stored model
    with pytest.raises(ModelError, match=r"computed for another system") as err:
        load_analysis(path, system=rotation(math.pi / 4))
    assert "modes[0].A" in str(err.value) and "'rotation'" in str(err.value)
    with pytest.raises(ModelError, match="computed for another system"):
        load_analysis(path, system=get_example("powertrain3").build())


# ------------------------------------------------------------------ edited files

def _edit_one_H_entry(data):
    region = next(r for r in data["regions"] if r["H"] and r["H"][0])
    region["H"][0][0] += 0.5


def test_one_edited_number_is_refused(saved):
    _rewrite(saved, _edit_one_H_entry)
    with pytest.raises(ModelError, match="checksum does not match") as err:
        load_analysis(saved)
    assert str(saved) in err.value.field and "edited or corrupted" in str(err.value)
    with pytest.raises(ModelError, match="checksum does not match"):
        load_analysis(saved, system=get_example("powertrain3").build())


def test_edited_model_is_refused(saved):
    def edit(data):
        data["system_model"]["modes"][0]["A"][0][0] += 1e-9

    _rewrite(saved, edit)
    with pytest.raises(ModelError, match="checksum does not match"):
        load_analysis(saved)
    _rewrite(saved, lambda data: None, fix_checksum=True)  # the edit with a checksum made to match
    with pytest.raises(ModelError, match="system_model") as err:
        load_analysis(saved)
    assert "fingerprint" in str(err.value)


def test_edited_fingerprint_is_refused(saved):
    def edit(data):
        data["system_fingerprint"] = "0" * 64

    _rewrite(saved, edit)
    with pytest.raises(ModelError, match="checksum does not match"):
        load_analysis(saved)
    _rewrite(saved, lambda data: None, fix_checksum=True)
    with pytest.raises(ModelError, match="fingerprint"):
        load_analysis(saved)
    with pytest.raises(ModelError, match="fingerprint"):
        load_analysis(saved, system=get_example("powertrain3").build())


def test_missing_checksum_is_refused(saved):
    _rewrite(saved, lambda data: data.pop("checksum"))
    with pytest.raises(ModelError, match="no checksum"):
        load_analysis(saved)


def test_version_1_file_is_refused_with_the_command_to_recompute(saved):
    def to_v1(data):
        for key in ("system_model", "system_fingerprint", "checksum"):
            data.pop(key)
        data["version"] = 1

    _rewrite(saved, to_v1)
    with pytest.raises(ModelError, match="version") as err:
        load_analysis(saved)
    assert "hybobs regions" in str(err.value) and "--out" in str(err.value)


# ------------------------------------------------------------------ no stored model

def test_file_without_model_but_with_example_name_still_loads(pt3, saved):
    plant, analysis = pt3
    _rewrite(saved, lambda data: data.pop("system_model"), fix_checksum=True)
    loaded = load_analysis(saved)  # rebuilt from the example name, fingerprint checked
    X = np.random.default_rng(3).uniform(*_box(plant.state_bounds), size=(50, plant.n))
    assert [loaded.classify(x) for x in X] == [analysis.classify(x) for x in X]
    tau = get_example("powertrain3").params["gear_ratio"]
    _rewrite(saved, lambda data: data.update(params={"gear_ratio": 1.1 * tau}), fix_checksum=True)
    with pytest.raises(ModelError, match="computed for another system"):
        load_analysis(saved)  # the example name builds another plant than the fingerprint's
    _rewrite(saved, lambda data: data.update(example=None), fix_checksum=True)
    with pytest.raises(ModelError, match="names no example"):
        load_analysis(saved)
