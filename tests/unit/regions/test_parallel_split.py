"""The parallel split of Algorithm 3.1 (paper 002): shared data sent once per worker, any cluster.

What is checked, and why:

* ``ProcessExecutor.map_shared`` with the shared data in a private file (the path for data of
  :data:`~hybobs_opt.executor.SHARED_FILE_MIN_BYTES` and more, forced here on small data)
  returns ``fn(item, shared)`` for every item in order, also over a second call with other data
  (a worker must not keep the first call's), and leaves no file behind.
* Model (17) at T = 5 on two processes through that path, and on a Dask cluster of two worker
  processes joined by its scheduler address (``DaskExecutor(scheduler=...)``, a LocalCluster
  started apart as a user's cluster would be), gives the pair lists and LP count recorded in
  ``tests/reproducibility_reference.json`` (sha256 of the pieces, thin and same-state pairs).
"""

import hashlib
import json
import os
import tempfile
from pathlib import Path

import pytest

from hybobs_opt import executor as executor_module
from hybobs_opt.executor import DaskExecutor, ProcessExecutor
from hybobs_opt.regions import analyse_observability, enumerate_modes
from hybobs_opt.studies import get_example

ROOT = Path(__file__).resolve().parents[3]


def _sha(pairs) -> str:
    return hashlib.sha256(json.dumps([[int(i), int(j)] for i, j in pairs], separators=(",", ":")).encode()).hexdigest()


def _shared_dirs() -> set:
    found = set()
    for where in {"/dev/shm", tempfile.gettempdir()}:
        if os.path.isdir(where):
            found |= {os.path.join(where, d) for d in os.listdir(where) if d.startswith("hybobs-shared-")}
    return found


def _scaled_sum(item, shared):
    return item * shared["factor"] + len(shared["pad"])


@pytest.fixture
def always_parallel(monkeypatch):
    from hybobs_opt.regions import enumeration, observability

    monkeypatch.setattr(enumeration, "PARALLEL_MIN_SEQUENCES", 0)
    monkeypatch.setattr(observability, "PARALLEL_MIN_PAIRS", 0)


def _check_reference(a):
    ref = json.loads((ROOT / "tests" / "reproducibility_reference.json").read_text())["powertrain5_T5_grouped"]
    assert (len(a.pairs), a.n_pair_lps) == (ref["n_pieces"], ref["n_pair_lps"])
    assert _sha(a.pairs.ij) == ref["sha256_pairs"]
    assert _sha(a.stats["pairs_dropped_thin"]) == ref["sha256_thin"]
    assert _sha(a.stats["pairs_dropped_same_state"]) == ref["sha256_same"]


def test_map_shared_through_a_file(monkeypatch):
    monkeypatch.setattr(executor_module, "SHARED_FILE_MIN_BYTES", 0)
    before = _shared_dirs()
    ex = ProcessExecutor(2)
    try:
        items = list(range(-3, 9))
        assert ex.map_shared(_scaled_sum, items, {"factor": 3, "pad": "x" * 10}) == [3 * k + 10 for k in items]
        assert ex.map_shared(_scaled_sum, items, {"factor": -2, "pad": ""}) == [-2 * k for k in items]
    finally:
        ex.close()
    assert _shared_dirs() == before


def test_processes_through_a_file_give_the_recorded_lists(monkeypatch, always_parallel):
    monkeypatch.setattr(executor_module, "SHARED_FILE_MIN_BYTES", 0)
    enum = enumerate_modes(get_example("powertrain5").build(), 5)
    ex = ProcessExecutor(2)
    try:
        a = analyse_observability(enum, executor=ex)
    finally:
        ex.close()
    assert a.stats["executor"] == "processes"
    _check_reference(a)


@pytest.mark.distributed
@pytest.mark.slow
def test_dask_cluster_joined_by_address_gives_the_recorded_lists(always_parallel):
    distributed = pytest.importorskip("distributed")
    enum = enumerate_modes(get_example("powertrain5").build(), 5)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        ex = DaskExecutor(scheduler=cluster.scheduler_address)
        try:
            assert ex.n_workers == 2
            a = analyse_observability(enum, executor=ex)
        finally:
            ex.close()
    assert a.stats["executor"] == "dask"
    _check_reference(a)
