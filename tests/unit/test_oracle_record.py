"""The recorded oracle verdicts (``tests/oracle_record.py``): a record is used only for the oracle
and the system it was made with, and a recorded verdict the live oracle does not give again
fails the test that relies on it."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import exact_oracle
import oracle_record
from canonical import slab_pwa
from oracle_record import OracleRecord, StaleRecord

T = 2


@pytest.fixture()
def records(tmp_path, monkeypatch):
    monkeypatch.setattr(oracle_record, "RECORDS", tmp_path)
    return tmp_path


def _system(seed: int = 3):
    return slab_pwa(seed, 2, 2, blind_probability=None)


def _open(system, name="r"):
    return OracleRecord(name, system, T, "state", system.scales()[0][: system.n])


def _states():
    rng = np.random.default_rng(7)
    return rng.uniform(-0.6, 0.6, (16, 2))


def _record(monkeypatch, system, name="r"):
    monkeypatch.setenv("HYBOBS_ORACLE", "record")
    rec = _open(system, name)
    verdicts = [rec.verdict(x) for x in _states()]
    rec.save()
    monkeypatch.setenv("HYBOBS_ORACLE", "recorded")
    return verdicts


def test_recorded_verdicts_equal_the_live_oracle_and_are_spot_checked(records, monkeypatch):
    system = _system()
    written = _record(monkeypatch, system)
    live = [exact_oracle.analyse_state(system, T, x) for x in _states()]
    assert [v.label for v in written] == [v.label for v in live]
    assert len({v.label for v in live}) > 1  # the record holds more than one kind of answer
    rec = _open(system)
    assert rec.usable
    got = [rec.verdict(x) for x in _states()]
    assert [(v.label, v.allowed) for v in got] == [(v.label, frozenset(v.allowed)) for v in live]
    assert rec.counts["spot_checks"] == 2 and rec.counts["recorded"] == 14 and rec.counts["live"] == 2


def test_a_state_within_the_match_tolerance_reuses_the_verdict_and_one_beyond_it_does_not(records, monkeypatch):
    system = _system()
    _record(monkeypatch, system)
    rec = _open(system)
    x = rec.keys[1]  # not a spot-checked entry (index 1)
    half = system.scales()[0][: system.n]
    rec.verdict(x + 0.1 * oracle_record.MATCH_TOL * half)
    assert rec.counts["recorded"] == 1 and rec.counts["live"] == 0
    rec.verdict(x + 1e3 * oracle_record.MATCH_TOL * half)
    assert rec.counts["not_in_record"] == 1 and rec.counts["live"] == 1


def _tamper(path, index):
    data = json.loads(path.read_text())
    key, old, _ = data["verdicts"][index]
    new = "unobservable" if old != "unobservable" else "observable"
    data["verdicts"][index] = [key, new, [new]]
    path.write_text(json.dumps(data))
    return old, new, np.array(key)


def test_a_tampered_verdict_that_the_toolbox_contradicts_is_re_decided_and_fails(records, monkeypatch):
    system = _system()
    _record(monkeypatch, system)
    old, new, x = _tamper(records / "r.json", 3)
    rec = _open(system)
    assert rec.verdict(x).label == new  # unchallenged, the (wrong) record is what it says
    with pytest.raises(StaleRecord, match="the toolbox disagrees"):
        rec.verdict(x, toolbox=old)


@pytest.mark.parametrize("index, mode, why", [(0, "recorded", "spot check"), (5, "live", "live mode")])
def test_a_tampered_verdict_fails_its_spot_check_and_live_mode(records, monkeypatch, index, mode, why):
    """Entry 0 is spot-checked in every run; entry 5 (not spot-checked) only in live mode."""
    system = _system()
    _record(monkeypatch, system)
    _, _, x = _tamper(records / "r.json", index)
    monkeypatch.setenv("HYBOBS_ORACLE", mode)
    with pytest.raises(StaleRecord, match=why):
        _open(system).verdict(x)


def test_a_record_of_another_system_or_oracle_is_not_used(records, monkeypatch):
    system = _system()
    _record(monkeypatch, system)
    other = _system(seed=4)
    with pytest.warns(UserWarning, match="system's data"):
        rec = _open(other)
    assert not rec.usable
    rec.verdict(_states()[1])
    assert rec.counts["live"] == 1 and rec.counts["recorded"] == 0
    monkeypatch.setattr(oracle_record, "oracle_digest", lambda: "0" * 64)
    with pytest.warns(UserWarning, match="oracle's source"):
        assert not _open(system).usable
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        monkeypatch.undo()
        monkeypatch.setattr(oracle_record, "RECORDS", records)
        assert _open(system).usable


def test_a_bad_mode_is_an_error(monkeypatch):
    monkeypatch.setenv("HYBOBS_ORACLE", "cached")
    with pytest.raises(ValueError, match="HYBOBS_ORACLE"):
        oracle_record.mode()


def test_a_live_verdict_that_overlaps_the_record_replaces_it_and_is_counted(records, monkeypatch):
    """A state within the oracle's margins may be decided otherwise on another CPU: the live
    verdict is used (the toolbox is judged against it) and counted, not a failure."""
    system = _system()
    _record(monkeypatch, system)
    path = records / "r.json"
    data = json.loads(path.read_text())
    key, old, _ = data["verdicts"][0]  # a spot-checked entry
    other = "unobservable" if old != "unobservable" else "observable"
    data["verdicts"][0] = [key, "ambiguous", sorted({old, other})]
    path.write_text(json.dumps(data))
    rec = _open(system)
    v = rec.verdict(np.array(key))
    assert v.label == old and rec.counts["changed"] == 1 and rec.counts["spot_checks"] == 1
