"""The lookup observer's packed tables (issue 19): ``step()`` and ``run()`` through
``_lookup_kernels.step_packed`` / ``run_packed`` give, bit for bit, what the previous
implementation gave -- the 42-argument kernels ``advance`` / ``run_table`` on separate arrays,
still in the module and run here side by side on the same tables -- and agree with each other.

Cases: the bench scenario of model (16) at T = 3 (noise-free and noisy, with NaN, Inf, an input
outside ``U``, a wrong length and a string), and the dead-zone spring at T = 4 (``canonical.py``),
whose windows the ``B~_T`` LPs decide (so the cuts the Python layer writes into the packed arrays
are read by the kernel)."""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt import analyse_observability, simulate_pwa
from hybobs_opt.contract import Estimate, timed_estimate
from hybobs_opt.observers import _lookup_kernels as K
from hybobs_opt.observers.lookup import _FLAGS, LookupObserver
from hybobs_opt.studies.paper002_powertrain.bench import bench_trace

from canonical import deadzone_drive, deadzone_spring


def _reference_run(obs: LookupObserver, U: np.ndarray, Y: np.ndarray):
    """The previous implementation of ``run()``: ``run_table`` on the separate arrays, from a reset."""
    obs.reset()
    N = U.shape[0]
    xs, modes = np.empty((N, obs.n)), np.empty(N, dtype=np.int64)
    codes, reasons = np.empty(N, dtype=np.int64), np.zeros(N, dtype=np.int64)
    t = 0
    while t < N:
        t = K.run_table(U, Y, t, obs._ints, obs._reals, obs._Ybuf, obs._Ubuf, obs._xcur, obs._meta, obs._uprev,
                        obs._z, obs._xs0, obs._xnew, *obs._tables, xs, modes, codes, reasons)
        if t < N:
            codes[t] = obs._decide_candidate()
            reasons[t] = obs._meta[5]
            xs[t], modes[t] = obs._xcur, obs._meta[1]
            t += 1
    return xs, modes, codes, reasons


def _reference_step(obs: LookupObserver, u: np.ndarray, y: np.ndarray, good: bool):
    """The previous implementation of one step: ``advance`` on the separate arrays."""
    ints = obs._ints.copy()
    ints[5] = 1 if good else 0
    code = K.advance(u, y, ints, obs._reals, obs._Ybuf, obs._Ubuf, obs._xcur, obs._meta, obs._uprev, obs._z,
                     obs._xs0, obs._xnew, *obs._tables)
    if code == K.CANDIDATE_CODE:
        code = obs._decide_candidate()
    return obs._xcur.copy(), int(obs._meta[1]), _FLAGS[code], int(obs._meta[5])


def _scenario(which: int):
    if which < 2:
        noise = (0.0, 0.01)[which]
        _, trace, y, analysis = bench_trace("powertrain3", 3, 1200, noise)
        U, Y = np.ascontiguousarray(trace.u, dtype=float), np.ascontiguousarray(y, dtype=float)
        U[100] = np.nan
        Y[200, 0] = np.inf
        U[300] = 1e6
        return analysis, U, Y
    plant = deadzone_spring()
    U = deadzone_drive(900)
    Y = simulate_pwa(plant, np.zeros(2), U).y.copy()
    Y[50] = np.nan
    return analyse_observability(plant, 4), U, Y


@pytest.fixture(scope="module", params=range(3), ids=["model16", "model16-noisy", "deadzone-T4"])
def case(request):
    return _scenario(request.param)


@pytest.mark.parametrize("variant", ["table", "exact"])
def test_packed_step_and_run_equal_the_separate_array_kernels_bit_for_bit(case, variant):
    analysis, U, Y = case
    new, old = LookupObserver(analysis, variant=variant), LookupObserver(analysis, variant=variant)
    run_new = new.run(U, Y)
    xs, modes, codes, reasons = _reference_run(old, U, Y)
    assert np.array_equal(run_new.x_hat, xs)
    assert np.array_equal(run_new.mode, modes)
    assert list(run_new.flags) == [_FLAGS[c] for c in codes]
    assert np.array_equal(run_new.reason_codes, reasons)

    new.reset()
    old.reset()
    for k in range(U.shape[0]):
        est = new.step(U[k], Y[k])
        x, mode, flag, rc = _reference_step(old, U[k], Y[k], True)
        assert est.x.tobytes() == x.tobytes() and est.mode == mode and est.flag == flag, k
        assert est.x.tobytes() == run_new.x_hat[k].tobytes() and est.flag == run_new.flags[k], k
        assert est.mode == run_new.mode[k], k
        if flag == "fallback":
            assert est.info["reason_code"] == rc
    # other samples take the checked path: a (1, m) array is a sample (flattened), a wrong length or
    # a string a bad one; the state they leave is the previous implementation's
    for u, ref_u, good in ((np.array([[U[5, 0]]]), U[5], True), ([1.0, 2.0, 3.0], old._nan_u, False),
                           ("x", old._nan_u, False)):
        est = new.step(u, Y[5])
        x, mode, flag, rc = _reference_step(old, ref_u, Y[5] if good else old._nan_y, good)
        assert (est.flag, est.mode, est.x.tobytes()) == (flag, mode, x.tobytes())
        if not good:
            assert est.flag == "fallback" and est.info["reason_code"] == K.REASON_BAD_SHAPE
    if new._pairs is not None:
        assert new._pairs.stats() == old._pairs.stats()


def test_samples_in_other_layouts_give_the_same_estimates(case):
    """float32, int, a list, a strided column view, a read-only array: converted, same answers."""
    analysis, U, Y = case
    a, b = LookupObserver(analysis), LookupObserver(analysis)
    Uf = np.asfortranarray(U)
    ro = Y.copy()
    ro.setflags(write=False)
    for k in range(min(U.shape[0], 400)):
        ea = a.step(U[k], Y[k])
        eb = b.step(list(Uf[k]), ro[k]) if k % 2 else b.step(Uf[k], ro[k].astype(np.float64).tolist())
        assert ea.x.tobytes() == eb.x.tobytes() and (ea.mode, ea.flag, ea.info) == (eb.mode, eb.flag, eb.info), k


def test_estimate_state_is_a_copy_and_the_packed_tables_are_views(case):
    analysis, U, Y = case
    obs = LookupObserver(analysis)
    est = obs.step(U[0], Y[0])
    assert not np.shares_memory(est.x, obs._F)
    for name in ("_table", "_offset", "_Ybuf", "_xcur", "_Pl", "_guard"):
        assert np.shares_memory(getattr(obs, name), obs._F), name
    for name in ("_meta", "_mstarts", "_last_mode"):
        assert np.shares_memory(getattr(obs, name), obs._I), name
    obs.reset()
    assert np.all(obs._Ybuf == 0) and obs._meta[0] == 0 and obs._meta[1] == -1


def test_timed_estimate_equals_the_dataclass():
    x = np.array([1.0, 2.0])
    est = timed_estimate(x, 3, "observable", {"a": 1}, 0.0)
    ref = Estimate(x, 3, "observable", est.seconds, {"a": 1})
    assert repr(est) == repr(ref) and est.seconds > 0
    assert (est.x is x, est.mode, est.flag, est.info) == (True, 3, "observable", {"a": 1})
    with pytest.raises(AttributeError):
        est.mode = 4


@pytest.mark.parametrize("which", [0, 2], ids=["model16", "deadzone-T4"])
def test_constructor_warm_up_step_leaves_no_trace(which):
    """The constructor's warm-up step (a sample without output, then a reset) changes nothing: the
    steps of a new observer equal those of one reset by hand after steps on other data, no LP was
    counted and no cut learnt (model 16; the dead-zone spring, whose windows need B~_T LPs).
    (Dropping the final reset alone does not fail this: a fallback step from a fresh state leaves
    nothing the next steps read; the test guards what a user can see.)"""
    analysis, U, Y = _scenario(which)
    U, Y = U[:400], Y[:400]
    fresh = LookupObserver(analysis)
    st = fresh.stats()
    assert st["n_btilde_lps"] == st["n_btilde_windows_with_lps"] == st["n_btilde_cuts"] == 0
    assert int(np.sum(fresh._pairs.cut_count)) == 0
    used = LookupObserver(analysis)
    for k in range(5):
        used.step(U[-1 - k], Y[-1 - k] * 1.1)  # other data
    used.reset()
    used._pairs._start_counters()  # and forget what it learnt, as a new observer has
    used._build_kernel_args()
    used.reset()
    for k in range(U.shape[0]):
        a, b = fresh.step(U[k], Y[k]), used.step(U[k], Y[k])
        assert np.array_equal(a.x, b.x) and a.mode == b.mode and a.flag == b.flag, k


def test_screen_memory_changes_no_answer(case):
    """The kernel tries first the row that last excluded each ``B~_T`` piece and each region; an
    observer whose memory is reset to the plain row order before every step gives the same
    estimates, modes, flags and reasons, bit for bit."""
    analysis, U, Y = case
    memo, plain = LookupObserver(analysis), LookupObserver(analysis)
    first_rows = plain._pairs.ex_starts[:-1].copy(), plain._mstarts[:-1].copy()
    for k in range(U.shape[0]):
        plain._pairs.ex_last[:], plain._m_last[:] = first_rows
        a, b = memo.step(U[k], Y[k]), plain.step(U[k], Y[k])
        assert (a.x.tobytes(), a.mode, a.flag, a.info) == (b.x.tobytes(), b.mode, b.flag, b.info), k
    moved = int(np.sum(memo._pairs.ex_last != first_rows[0]) + np.sum(memo._m_last != first_rows[1]))
    assert moved > 0  # the memory was used


def test_step_estimate_behaves_as_the_dataclass(case):
    import copy
    import dataclasses
    import pickle

    analysis, U, Y = case
    obs = LookupObserver(analysis)
    for k in range(4):
        est = obs.step(U[k], Y[k])
    ref = Estimate(est.x, est.mode, est.flag, est.seconds, est.info)
    assert isinstance(est, Estimate) and repr(est) == repr(ref)
    assert [f.name for f in dataclasses.fields(est)] == [f.name for f in dataclasses.fields(ref)]
    assert repr(dataclasses.replace(est, flag="fallback")) == repr(dataclasses.replace(ref, flag="fallback"))
    for other in (pickle.loads(pickle.dumps(est)), copy.deepcopy(est), copy.copy(est)):
        assert repr(other) == repr(ref) and other.x is not obs._xcur
    with pytest.raises(dataclasses.FrozenInstanceError):
        est.flag = "fallback"
    with pytest.raises(AttributeError):
        est.other = 1
