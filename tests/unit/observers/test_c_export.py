"""The lookup-table observer exported as C99 (issue 20; paper 002, Algorithm 4.1).

The exported code is compiled with ``cc -std=c99 -Wall -Werror -O2`` and replayed through its
generated driver; every answer is compared with the Python observer's ``run`` on the same samples
(an independent implementation: numpy tables, the numba kernel, certified LPs for ``B~_T``):

* model (16) at T = 3 on the bench scenario (2,000 samples) with bad samples (NaN, Inf, inputs
  outside ``U``, an output of 1e12): double precision equal to 1e-12 relative, every flag, mode and
  reason equal; single precision with every flag equal;
* the dead-zone spring of ``canonical.py`` (not from the papers) at T = 4, whose windows are
  decided by the ``B~_T`` LPs (hits and exclusions), and at T = 2 with the exact projections of
  ``B~_T`` (``b_tilde="project"``, no LP);
* the refusals (exact variant, names, files, the table limit, single precision where it cannot
  resolve the candidates).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.observers import _lookup_kernels as K
from hybobs_opt.observers.c_export import CExport, export_lookup_c
from hybobs_opt.observers.lookup import LookupObserver
from hybobs_opt.regions import analyse_observability
from hybobs_opt.sim import simulate_pwa
from hybobs_opt.studies.paper002_powertrain.bench import bench_trace

from c_replay import FLAGS, build, relative_error, replay, require_cc, sizes
from canonical import deadzone_drive, deadzone_spring

#: Double precision: the same operations in the same order (issue 20 asks for 1e-12 relative).
DOUBLE_RTOL = 1e-12
#: Single precision, as a fraction of each state's half-range: on windows flagged observable (the
#: reconstruction; issue 20 asks for 1e-4 relative) and on every sample (open-loop predictions from
#: a reconstruction accumulate rounding over hundreds of steps).
FLOAT32_RANGE_TOL_OBSERVABLE = 1e-4
FLOAT32_RANGE_TOL_ALL = 2e-3


def _bad_samples_powertrain(U, Y):
    U, Y = U.copy(), Y.copy()
    U[300] = np.nan
    Y[600] = np.inf
    U[900] = -1e-3            # below T_m >= 0: outside U
    U[1200] = 140.0 + 1e-3    # above T_m <= 140
    U[1250] = -1e-12          # on the bound up to rounding: an ordinary sample
    Y[1500] = 1e12            # an output no mode produces
    Y[1700:1702] = np.nan     # two bad samples in a row (no prediction after the first)
    U[1800] = -np.inf
    return U, Y


@pytest.fixture(scope="module")
def model16():
    """Model (16), T = 3: the bench scenario of ``hybobs bench`` (2,000 samples) with bad samples, and the Python run."""
    plant, trace, y, analysis = bench_trace("powertrain3", 3, 2000, 0.0)
    obs = LookupObserver(analysis)
    U, Y = _bad_samples_powertrain(trace.u, y)
    return plant, obs, U, Y, obs.run(U, Y)


@pytest.fixture(scope="module")
def deadzone():
    """The dead-zone spring (not from the papers), T = 4, 1,500 samples through the dead zone, with bad samples."""
    system = deadzone_spring()
    analysis = analyse_observability(system, 4)
    obs = LookupObserver(analysis)
    trace = simulate_pwa(system, np.zeros(2), deadzone_drive(1500))
    U, Y = trace.u.copy(), trace.y.copy()
    U[200] = np.nan
    U[400] = 1.5      # outside |u| <= 1
    Y[700] = 1e9
    Y[900] = -np.inf
    return system, obs, U, Y, obs.run(U, Y)


def _assert_same_as_python(rep, ref, rtol=DOUBLE_RTOL):
    assert list(rep.flags) == list(ref.flags)
    np.testing.assert_array_equal(rep.mode, ref.mode)
    np.testing.assert_array_equal(rep.reasons, ref.reason_codes)
    err = relative_error(rep.x, ref.x_hat)
    assert err.max() <= rtol, (err.max(), np.unravel_index(err.argmax(), err.shape))


def test_model16_double_equals_the_python_observer(model16, tmp_path):
    """Model (16), T = 3, with bad samples: estimates to 1e-12, every flag, mode and reason code equal."""
    plant, obs, U, Y, ref = model16
    counts = ref.flag_counts()
    assert counts["observable"] > 1000 and counts["unobservable"] > 200 and counts["fallback"] == 7
    assert counts["warming_up"] >= 6 * (obs.T - 1)  # the window refills after each bad sample
    assert set(ref.reason_codes[ref.flags == "fallback"]) == {K.REASON_NONFINITE, K.REASON_INPUT_OUTSIDE_U}
    assert K.REASON_PREVIOUS_BAD in set(ref.reason_codes)  # the samples after a bad one (no prediction)
    export = export_lookup_c(obs, tmp_path / "c")
    assert isinstance(export, CExport) and export.btilde_test == "pairs" and not export.float32
    exe = build(export)
    rep = replay(exe, plant, U, Y, tmp_path)
    _assert_same_as_python(rep, ref)
    # the header's figures are the compiler's: tables in flash, the state struct in RAM
    size = sizes(exe)
    assert size["table_bytes"] == export.table_bytes
    assert size["state_bytes"] >= export.state_bytes and size["state_bytes"] <= export.state_bytes + 16
    header = export.header.read_text()
    assert f"{export.table_bytes:,} bytes" in header and f"{export.max_ops:,} multiply-adds" in header
    assert export.max_ops == sum(export.ops.values()) and export.ops["window"] == obs._table.size
    assert "#include" not in export.source.read_text().replace('#include <math.h>', "").replace(
        f'#include "{export.name}.h"', "")  # nothing beyond math.h
    for word in ("malloc", "calloc", "free(", "printf", "stdlib"):
        assert word not in export.source.read_text()


def test_model16_float32_has_the_same_flags(model16, tmp_path):
    """Single precision, model (16), T = 3: every flag equal, reconstructions within 1e-4 of each state's range."""
    plant, obs, U, Y, ref = model16
    export = export_lookup_c(obs, tmp_path / "c", float32=True)
    assert export.float32 and 0 < export.float32_rounding < 0.05
    assert "typedef float hybobs_lookup_real;" in export.header.read_text()
    assert re.search(r"static const real TAB\[\d+\] = \{\n    -?\d[^,]*f,", export.source.read_text())
    exe = build(export)
    assert sizes(exe)["table_bytes"] == export.table_bytes < export_lookup_c(obs, tmp_path / "d").table_bytes
    rep = replay(exe, plant, U, Y, tmp_path)
    assert list(rep.flags) == list(ref.flags)
    np.testing.assert_array_equal(rep.reasons, ref.reason_codes)
    lo, hi = plant.state_bounds.bounding_box()
    scaled = np.abs(rep.x - ref.x_hat) / ((hi - lo) / 2)
    observable = ref.flags == "observable"
    assert scaled[observable].max() <= FLOAT32_RANGE_TOL_OBSERVABLE
    assert scaled.max() <= FLOAT32_RANGE_TOL_ALL
    assert 1e-9 < relative_error(rep.x, ref.x_hat).max()  # it is single precision
    # modes: equal wherever reconstructed; an open-loop prediction may take the other side of a
    # guard only where the double-precision estimate it came from lies within rounding of that guard
    np.testing.assert_array_equal(rep.mode[observable], ref.mode[observable])
    for k in np.nonzero(rep.mode != ref.mode)[0]:
        assert ref.flags[k] != "observable"
        assert _guard_distance(plant, ref.x_hat[k - 1], U[k - 1]) < FLOAT32_RANGE_TOL_ALL, k


def _guard_distance(system, x, u) -> float:
    """Smallest distance of ``(x, u)`` to a guard hyperplane, in coordinates scaled by the half-ranges."""
    lo, hi = system.domain.bounding_box()
    scale = (hi - lo) / 2
    z = np.concatenate([x, u])
    best = np.inf
    for mode in system.modes:
        G = mode.guard
        A = G.A if G.dim == z.size else np.hstack([G.A, np.zeros((G.A.shape[0], z.size - G.dim))])
        best = min(best, float(np.min(np.abs(A @ z - G.b) / np.linalg.norm(A * scale, axis=1))))
    return best


def test_deadzone_spring_btilde_lps_decide_like_the_python_observer(deadzone, tmp_path):
    """A system not from the papers, T = 4: windows decided by B~_T LPs (in and out), bad samples; double exact."""
    system, obs, U, Y, ref = deadzone
    stats = obs.stats()
    assert stats["n_btilde_pieces"] > 50 and stats["n_btilde_hits"] > 10
    assert stats["n_btilde_lps"] > stats["n_btilde_hits"]  # some LPs exclude the state, too
    counts = ref.flag_counts()
    assert counts["observable"] > 800 and counts["unobservable"] > 200 and counts["fallback"] == 3
    export = export_lookup_c(obs, tmp_path / "c", name="deadzone_obs")
    assert export.header.name == "deadzone_obs.h" and "deadzone_obs_step" in export.header.read_text()
    exe = build(export)
    rep = replay(exe, system, U, Y, tmp_path)
    _assert_same_as_python(rep, ref)
    assert rep.stats["lps"] >= stats["n_btilde_hits"] and rep.stats["lp_limits"] == 0
    assert 0 < rep.stats["max_pivots"] <= 2 * (export.sizes["lp_max_rows"] + export.sizes["lp_max_columns"] + 2)


def test_deadzone_spring_float32(deadzone, tmp_path):
    system, obs, U, Y, ref = deadzone
    export = export_lookup_c(obs, tmp_path / "c", float32=True)
    rep = replay(build(export), system, U, Y, tmp_path)
    assert list(rep.flags) == list(ref.flags)
    lo, hi = system.state_bounds.bounding_box()
    scaled = np.abs(rep.x - ref.x_hat) / ((hi - lo) / 2)
    assert scaled[ref.flags == "observable"].max() <= FLOAT32_RANGE_TOL_OBSERVABLE
    assert rep.stats["lp_limits"] == 0


def test_projected_btilde_is_a_point_in_union_test(tmp_path):
    """``b_tilde="project"`` (exact projections, eq. 15): exported without any LP, same answers."""
    require_cc()
    system = deadzone_spring()
    obs = LookupObserver(analyse_observability(system, 2), b_tilde="project")
    assert len(obs.b_tilde) > 5
    trace = simulate_pwa(system, np.zeros(2), deadzone_drive(600))
    ref = obs.run(trace.u, trace.y)
    export = export_lookup_c(obs, tmp_path / "c")
    assert export.btilde_test == "polytopes" and export.ops["btilde_lps"] == 0
    assert "lp_inside" not in export.source.read_text().split("#else")[1]
    rep = replay(build(export), system, trace.u, trace.y, tmp_path)
    _assert_same_as_python(rep, ref)
    assert rep.stats["lps"] == 0 and ref.flag_counts()["observable"] > 300


def test_an_analysis_is_exported_with_the_default_observer(tmp_path):
    system = deadzone_spring()
    analysis = analyse_observability(system, 3)
    a = export_lookup_c(analysis, tmp_path / "a")
    b = export_lookup_c(LookupObserver(analysis), tmp_path / "b")
    assert a.source.read_text() == b.source.read_text() and a.to_dict()["table_bytes"] == b.table_bytes


def test_refusals(model16, tmp_path, monkeypatch):
    import hybobs_opt.observers.c_export as ce

    plant, obs, *_ = model16
    with pytest.raises(ModelError, match="^observer: expected a LookupObserver"):
        export_lookup_c(plant, tmp_path / "x")
    with pytest.raises(ModelError, match="^observer: .*'exact'"):
        export_lookup_c(LookupObserver(obs.analysis, variant="exact"), tmp_path / "x")
    for bad in ("2fast", "my-observer", "int", "", 7):
        with pytest.raises(ModelError, match="^name: expected a C identifier"):
            export_lookup_c(obs, tmp_path / "x", name=bad)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ModelError, match="^out_dir: expected a directory"):
        export_lookup_c(obs, tmp_path / "file")
    with pytest.raises(ModelError, match="^float32: expected True or False"):
        export_lookup_c(obs, tmp_path / "x", float32="yes")
    monkeypatch.setattr(ce, "MAX_EXPORT_TABLE_BYTES", 1000)
    with pytest.raises(ModelError, match=r"^tables: expected tables of at most 1,000 bytes .*MAX_EXPORT_TABLE_BYTES.*T = 3"):
        export_lookup_c(obs, tmp_path / "y")
    monkeypatch.setattr(ce, "C_EXPORT_F32_MAX_ROUNDING", 1e-6)
    with pytest.raises(ModelError, match=r"^float32: .*double precision.*rounding bound"):
        export_lookup_c(obs, tmp_path / "z", float32=True)
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists() and not (tmp_path / "z").exists()


def test_driver_reads_a_log_in_any_column_order_and_reports_bad_input(model16, tmp_path):
    """The driver finds the columns by name, reads a non-number as NaN and refuses a log without an input column."""
    import subprocess

    plant, obs, U, Y, ref = model16
    exe = build(export_lookup_c(obs, tmp_path / "c"))
    log = tmp_path / "swapped.csv"
    rows = ["omega_m,extra,T_m"] + [f"{float(Y[k, 0])!r},1,{float(U[k, 0])!r}" for k in range(50)]
    rows[11] = f"{float(Y[10, 0])!r},1,abc"  # sample 10: not a number
    log.write_text("\n".join(rows) + "\n")
    r = subprocess.run([str(exe), str(log), str(tmp_path / "o.csv")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = (tmp_path / "o.csv").read_text().splitlines()
    assert out[0] == "theta,omega_m,omega_l,mode,flag,reason"  # no time column in this log
    U2 = U[:50].copy()
    U2[10] = np.nan
    ref2 = obs.run(U2, Y[:50])
    assert [line.split(",")[4] for line in out[1:]] == list(ref2.flags)
    assert ref2.flags[10] == "fallback"
    (tmp_path / "no_input.csv").write_text("omega_m\n1\n")
    r = subprocess.run([str(exe), str(tmp_path / "no_input.csv"), str(tmp_path / "o.csv")], capture_output=True, text=True)
    assert r.returncode == 2 and "missing input column T_m" in r.stderr
    assert FLAGS == ("observable", "unobservable", "fallback", "warming_up")
