"""Lookup-table deadbeat observer (paper 002, Algorithm 4.1)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybobs_opt.examples import get_example
from hybobs_opt.examples.powertrain import powertrain3
from hybobs_opt.observers.base import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP
from hybobs_opt.observers.lookup import LookupObserver
from hybobs_opt.regions import analyse_observability, load_analysis, save_analysis
from hybobs_opt.sim import simulate_pwa

from test_regions import _random_pwa


@pytest.fixture(scope="module")
def setup():
    plant = powertrain3()
    trace = get_example("powertrain3").scenario(plant)
    analysis = analyse_observability(plant, 3)
    return plant, trace, analysis, LookupObserver(analysis)


def test_exact_reconstruction_where_flagged_observable(setup):
    """Noise-free model (16), T = 3: the estimate equals the true state (1e-9 relative) at every observable step."""
    plant, trace, analysis, obs = setup
    out = obs.run(trace.u, trace.y)
    sel = out.flags == OBSERVABLE
    assert sel.sum() > 0.4 * trace.n_samples
    rel = np.abs(out.x_hat[sel] - trace.x[sel]) / np.maximum(1.0, np.abs(trace.x[sel]))
    assert rel.max() < 1e-9
    assert np.all(out.mode[sel] == trace.q[sel])


def test_backlash_crossings_flagged_unobservable(setup):
    """Windows whose true mode sequence has rank C_i < n (the shaft in the backlash) are never reconstructed."""
    plant, trace, analysis, obs = setup
    out = obs.run(trace.u, trace.y)
    seqs = {r.sequence: k for k, r in enumerate(analysis.regions)}
    T = analysis.T
    deficient = 0
    for t in range(T - 1, trace.n_samples):
        seq = tuple(int(v) for v in trace.q[t - T + 1 : t + 1])
        if seq in seqs and not analysis.full_rank[seqs[seq]]:
            deficient += 1
            assert out.flags[t] == UNOBSERVABLE, (t, seq)
    assert deficient > 100  # the scenario does cross the backlash
    assert np.all(out.flags[: T - 1] == WARMING_UP)


def test_step_and_run_agree(setup):
    plant, trace, analysis, obs = setup
    out = obs.run(trace.u[:1200], trace.y[:1200])
    obs.reset()
    for k in range(1200):
        e = obs.step(trace.u[k], trace.y[k])
        assert e.flag == out.flags[k]
        np.testing.assert_allclose(e.x, out.x_hat[k], rtol=1e-9, atol=1e-9)


def test_exact_variant_agrees_with_table(setup):
    plant, trace, analysis, obs = setup
    a = obs.run(trace.u[900:1300], trace.y[900:1300])
    b = LookupObserver(analysis, variant="exact").run(trace.u[900:1300], trace.y[900:1300])
    assert list(a.flags) == list(b.flags)


def test_bad_samples_never_raise(setup):
    plant, trace, analysis, obs = setup
    obs.reset()
    for k in range(10):
        obs.step(trace.u[k], trace.y[k])
    for bad_u, bad_y in (([np.nan], trace.y[10]), (trace.u[10], [np.inf]), ([1.0, 2.0], trace.y[10]), ("x", trace.y[10])):
        e = obs.step(bad_u, bad_y)
        assert e.flag == FALLBACK and "reason" in e.info and np.all(np.isfinite(e.x))
    # the window refills and the observer reconstructs again
    flags = [obs.step(trace.u[k], trace.y[k]).flag for k in range(11, 20)]
    assert flags[-1] == OBSERVABLE
    U = trace.u[:50].copy()
    U[20] = np.nan
    out = obs.run(U, trace.y[:50])
    assert out.flags[20] == FALLBACK and out.flags[30] == OBSERVABLE


def test_saved_regions_file_drives_the_observer(setup, tmp_path):
    plant, trace, analysis, obs = setup
    path = save_analysis(analysis, tmp_path / "r.json", "powertrain3", {})
    again = LookupObserver(load_analysis(path))
    a, b = obs.run(trace.u[:600], trace.y[:600]), again.run(trace.u[:600], trace.y[:600])
    assert list(a.flags) == list(b.flags)
    np.testing.assert_allclose(a.x_hat, b.x_hat)


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), n_modes=st.integers(2, 3), T=st.integers(2, 3))
def test_never_flags_observable_a_wrong_state(seed, n_modes, T):
    """Random small PWA systems: every step flagged observable carries the true state."""
    system = _random_pwa(seed, 2, n_modes)
    analysis = analyse_observability(system, T)
    if not analysis.index_set:
        return
    obs = LookupObserver(analysis)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        x0 = rng.uniform(-0.5, 0.5, 2)
        U = rng.uniform(-1, 1, (40, 1))
        trace = simulate_pwa(system, x0, U, on_blocked="stop")
        if trace.n_samples < T + 1:
            continue
        out = obs.run(trace.u, trace.y)
        sel = out.flags == OBSERVABLE
        if sel.any():
            assert np.max(np.abs(out.x_hat[sel] - trace.x[sel])) < 1e-7


def test_bad_construction_arguments(setup):
    from hybobs_opt.errors import ModelError

    _, _, analysis, _ = setup
    with pytest.raises(ModelError, match="variant"):
        LookupObserver(analysis, variant="fast")
    with pytest.raises(ModelError, match="output_rtol"):
        LookupObserver(analysis, output_rtol=-1.0)
    with pytest.raises(ModelError, match="U, Y"):
        LookupObserver(analysis).run(np.zeros((5, 2)), np.zeros((5, 1)))


def test_cli_bench_json_contract(capsys):
    import json

    from hybobs_opt.cli import main

    code = main(["bench", "powertrain3", "--horizon", "3", "--steps", "1200", "--observers", "lookup", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    rec = out["observers"]["lookup"]
    for key in ("median_step_s", "p95_step_s", "max_abs_error_observable", "n_flagged_unobservable", "solver"):
        assert key in rec
    assert rec["max_abs_error_observable_all"] < 1e-9
    assert rec["batch_equals_steps"] is True
    assert main(["bench", "powertrain3", "--steps", "2"]) == 2
