"""Paper 001's observer scenarios: the sliding-mode observer (eq. 5) on Examples 1-3 (Figs. 3-7),
the noise / filter trade-off of Figs. 5-6 and 9, and a second system not from the paper (a
relay-driven oscillator whose switching depends on the unmeasured velocity).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.observers.sliding_mode import (
    IndicatorMetrics,
    SlidingModeObserver,
    SlidingModeRun,
    _json_float,
    convergence_times,
    indicator_metrics,
)
from hybobs_opt.synthesis.sliding_mode_gains import discretization_band
from hybobs_opt.systems.canonical_form import ObservabilityForm, observability_form
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.defaults import SMO_FILTER_STEPS

# ---------------------------------------------------------------------------------- a system not from the paper
def relay_oscillator(damping: float = 0.5, drive: float = 1.0, bound: float = 5.0) -> HybridAutomaton:
    """A second system, not from paper 001: a relay-driven (self-excited) oscillator, 2 states.

    ``p' = v``, ``v' = -p - damping v + drive`` where ``v >= 0`` (location ``push+``) and
    ``-p - damping v - drive`` where ``v <= 0`` (``push-``): a mass-spring-damper pushed in the
    direction of its velocity (a Froude-pendulum-like escapement).  The energy
    ``(p^2 + v^2)/2`` grows while ``|v| < drive/damping`` and settles on a limit cycle of
    amplitude ``~ 4 drive / (pi damping)`` (2.55 by default, by harmonic balance).  Measured
    ``y = p``; the switching function is the *unmeasured* velocity, so ``S_o`` must come from
    the estimate.  Already in form (4) (``T = I``), affine in each location.
    """
    for name, v in (("damping", damping), ("drive", drive), ("bound", bound)):
        if not (np.isfinite(v) and v > 0):
            raise ModelError(name, "a positive finite number", repr(v))
    names = ("p", "v")
    A = np.array([[0.0, 1.0], [-1.0, -damping]])
    C = np.array([[1.0, 0.0]])
    ev = np.array([[0.0, 1.0]])
    locs = (
        Location("push+", Polytope(-ev, np.zeros(1), names), A=A, E=np.array([0.0, drive]), C=C),
        Location("push-", Polytope(ev, np.zeros(1), names), A=A, E=np.array([0.0, -drive]), C=C),
    )
    return HybridAutomaton(
        locations=locs,
        state_bounds=Polytope.from_box([-bound, -bound], [bound, bound], names),
        edges=(Edge(0, 1), Edge(1, 0)),
        state_names=names,
        output_names=("y",),
        name="relay_oscillator (not from paper 001)",
    )


# ---------------------------------------------------------------------------------- scenarios
#: The observer starts this fraction of the operating range away from the plant in every
#: coordinate (alternating signs), the same rule for every scenario.
INITIAL_ERROR_FRACTION = 0.1


@dataclass(frozen=True)
class ScenarioSpec:
    """A plant, its initial state and the sampling of an observer scenario.

    Attributes
    ----------
    name : str
    build : callable
        ``build() -> HybridAutomaton``.
    x0 : callable
        ``x0(automaton) -> (n,) array``: the plant's initial state.
    Ts : float
        Sample period = observer step.
    t_final : float
    note : str
        Why these choices.
    """

    name: str
    build: Callable[[], HybridAutomaton]
    x0: Callable[[HybridAutomaton], np.ndarray]
    Ts: float
    t_final: float
    note: str


def _x0_triangular(a):
    from .systems import TRIANGULAR_X0

    return np.array(TRIANGULAR_X0, dtype=float)


def _x0_double_scroll(a):
    from .systems import DOUBLE_SCROLL_X0
    from hybobs_opt.sim.hybrid import simulate_hybrid

    # 20 s burn-in from the example's start: the run begins on the attractor
    return simulate_hybrid(a, np.array(DOUBLE_SCROLL_X0), 20.0, dt=0.05).x[-1]


def _build(name: str):
    def build():
        from . import systems

        return getattr(systems, name)()

    return build


SCENARIOS: dict[str, ScenarioSpec] = {
    "triangular": ScenarioSpec(
        "triangular", _build("triangular"), _x0_triangular, 1e-4, 3.0,
        "Example 2 from x(0) = (0, 0.01, -0.005); h = 0.1 ms because F2's slope in x3 (12 000 1/s) needs h * 12 000 < 2 "
        "for the Euler step of the model part",
    ),
    "double_scroll": ScenarioSpec(
        "double_scroll", _build("double_scroll"), _x0_double_scroll, 1e-3, 30.0,
        "Example 3 on the attractor (20 s burn-in from x(0) = (0.1, 0, 0)), observer in z = T x, h = 1 ms",
    ),
    "switched_unstable": ScenarioSpec(
        "switched_unstable", _build("switched_unstable"), lambda a: np.array([1.0, 0.0]), 1e-3, 10.0,
        "Example 1 from (1, 0): the switched system grows 4-fold per revolution; y = x1",
    ),
    "relay_oscillator": ScenarioSpec(
        "relay_oscillator", relay_oscillator, lambda a: np.array([0.5, 0.0]), 1e-3, 20.0,
        "not from the paper: relay-driven oscillator from (0.5, 0), y = p, switching on the unmeasured velocity",
    ),
}


@dataclass(frozen=True, eq=False)
class ScenarioResult:
    """One observer run on a scenario, with the truth and the measured figures.

    Attributes
    ----------
    spec : ScenarioSpec
    form : ObservabilityForm
    observer : SlidingModeObserver
    truth : Trace
        The plant, simulated with event location (:func:`~hybobs_opt.sim.hybrid.simulate_hybrid`)
        or with the fixed-step simulator, sampled every ``Ts``.
    y : (N,) array
        The output the observer received (with noise, if any).
    z_true : (N, n) array
    run : SlidingModeRun
    S : (N,) int array
        True switching indicator (the mode function applied to the true state).
    band : (n,) array
        Stated error band (:func:`discretization_band`; noise-free, so a noisy run may never
        enter it: its convergence times are then ``nan``).
    conv_times : (n,) array
        :func:`convergence_times` of each canonical state to ``band`` (``nan``: not reached).
    t_settled : float
        Time from which the indicator and the final error are measured: the first sample at which
        every stage slides (``E_n = 1``), i.e. the observer is in operation (independent of the
        band, so noisy runs are measured the same way).
    final_error : (n,) array
        ``max |zh - z|`` after ``t_settled``.
    final_error_x : (n,) array
        The same in the original coordinates.
    error_last_half : (n,) array
        ``max |zh - z|`` over the second half of the run (the steady error, without the settling
        just after convergence).
    indicator : IndicatorMetrics
        After ``t_settled``.
    noise : float
    """

    spec: ScenarioSpec
    form: ObservabilityForm
    observer: SlidingModeObserver
    truth: Any
    y: np.ndarray
    z_true: np.ndarray
    run: SlidingModeRun
    S: np.ndarray
    band: np.ndarray
    conv_times: np.ndarray
    t_settled: float
    final_error: np.ndarray
    final_error_x: np.ndarray
    error_last_half: np.ndarray
    indicator: IndicatorMetrics
    noise: float = 0.0

    @property
    def t(self) -> np.ndarray:
        return self.truth.t


def simulate_truth(automaton: HybridAutomaton, x0, t_final: float, Ts: float, plant: str = "events"):
    """The plant's trajectory sampled every ``Ts``: event-located (``"events"``) or fixed-step RK4."""
    if plant == "events":
        from hybobs_opt.sim.hybrid import simulate_hybrid

        return simulate_hybrid(automaton, np.asarray(x0, dtype=float), t_final, dt=Ts)
    if plant == "fixed_step":
        from hybobs_opt.sim.fixed_step import simulate_hybrid_fixed_step

        return simulate_hybrid_fixed_step(automaton, np.asarray(x0, dtype=float), t_final, dt=Ts)
    raise ModelError("plant", "'events' or 'fixed_step'", repr(plant))


def run_scenario(
    name: str,
    *,
    filter_tau: float | str | None = None,
    noise: float = 0.0,
    seed: int = 0,
    Ts: float | None = None,
    t_final: float | None = None,
    truth=None,
    form: ObservabilityForm | None = None,
    plant: str = "events",
) -> ScenarioResult:
    """Run observer (5) on a scenario of :data:`SCENARIOS` and measure it.

    Parameters
    ----------
    name : str
        ``"triangular"`` (Example 2), ``"double_scroll"`` (Example 3), ``"switched_unstable"``
        (Example 1) or ``"relay_oscillator"`` (not from the paper).
    filter_tau : float, "default" or None
        Low-pass filter of the switching decision (``"default"``: ``SMO_FILTER_STEPS * Ts``).
    noise : float
        Standard deviation of white Gaussian noise added to ``y`` (output units).
    seed : int
    Ts, t_final : float, optional
        Override the scenario's sampling and horizon.
    truth : Trace, optional
        Reuse a simulated plant (must be sampled every ``Ts``).
    form : ObservabilityForm, optional
        Reuse a computed canonical form.
    plant : {"events", "fixed_step"}
    """
    if name not in SCENARIOS:
        raise ModelError("scenario", f"one of {sorted(SCENARIOS)}", repr(name))
    spec = SCENARIOS[name]
    Ts = spec.Ts if Ts is None else float(Ts)
    t_final = spec.t_final if t_final is None else float(t_final)
    if not (np.isfinite(noise) and noise >= 0):
        raise ModelError("noise", "a non-negative standard deviation", repr(noise))
    automaton = form.automaton if form is not None else spec.build()
    form = form if form is not None else observability_form(automaton)
    if filter_tau == "default":
        filter_tau = SMO_FILTER_STEPS * Ts
    if truth is None:
        truth = simulate_truth(automaton, spec.x0(automaton), t_final, Ts, plant)
    elif truth.t.size > 1 and not np.isclose(truth.t[1] - truth.t[0], Ts, rtol=1e-9):
        raise ModelError("truth", f"a trace sampled every Ts = {Ts}", f"step {truth.t[1] - truth.t[0]}")
    y = truth.y[:, 0].copy()
    if noise > 0:
        y += noise * np.random.default_rng(seed).standard_normal(y.size)
    lo, hi = automaton.state_bounds.bounding_box()
    signs = np.where(np.arange(form.n) % 2 == 0, 1.0, -1.0)
    x_hat0 = truth.x[0] + INITIAL_ERROR_FRACTION * (hi - lo) * signs
    obs = SlidingModeObserver(form, Ts, filter_tau=filter_tau)
    run = obs.run_detailed(None, y, x_hat0)
    z_true = form.to_z(truth.x)
    S = form.modes_of(z_true)
    band = discretization_band(form, Ts)
    err = run.z_hat - z_true
    conv = convergence_times(truth.t, err, band)
    closed = np.nonzero(run.sliding[:, -1])[0]
    t_settled = float(truth.t[closed[0]]) if closed.size else float(truth.t[-1])
    after = truth.t >= t_settled
    final = np.abs(err[after]).max(axis=0)
    final_x = np.abs(run.trace.x_hat[after] - truth.x[after]).max(axis=0)
    half = truth.t >= 0.5 * truth.t[-1]
    last_half = np.abs(err[half]).max(axis=0)
    ind = indicator_metrics(truth.t[after], S[after], run.mode[after])
    return ScenarioResult(spec, form, obs, truth, y, z_true, run, S, band, conv, t_settled, final, final_x, last_half, ind,
                          float(noise))


def summarize(result: ScenarioResult) -> dict[str, Any]:
    """JSON-ready summary: ``convergence_times`` (in the order the states converge),
    ``final_error_band``, ``indicator_mismatch_fraction`` and the details."""
    names = result.form.names
    xnames = result.form.automaton.state_names
    order = [j for j in np.argsort(np.where(np.isfinite(result.conv_times), result.conv_times, np.inf), kind="stable")]
    tr = result.run.trace
    return {
        "example": result.spec.name,
        "observer": result.observer.name,
        "Ts": result.observer.Ts,
        "t_final": float(result.t[-1]),
        "noise": result.noise,
        "filter_tau": result.observer.filter_tau,
        "coordinates": "z = T x + d (observability form)" if not result.form.is_identity else "x (already in form (4))",
        "gains": result.observer.gains.to_dict(),
        "band": {names[j]: float(result.band[j]) for j in range(result.form.n)},
        "convergence_times": [{"state": names[j], "t": _json_float(result.conv_times[j])} for j in order],
        "converged_in_order": bool(np.all(np.isfinite(result.conv_times)) and np.all(np.diff(result.conv_times) >= 0)),
        "final_error_band": {names[j]: float(result.final_error[j]) for j in range(result.form.n)},
        "final_error_band_original": {xnames[j]: float(result.final_error_x[j]) for j in range(result.form.n)},
        "error_last_half": {names[j]: float(result.error_last_half[j]) for j in range(result.form.n)},
        "indicator_mismatch_fraction": result.indicator.mismatch_fraction,
        "indicator": result.indicator.to_dict(),
        "measured_from_t": result.t_settled,
        "flags": tr.flag_counts(),
        "compute_time_per_step_s": tr.timing()["median_step_s"],
    }


#: Output noise of the filter trade-off, as a fraction of the output's range over the scenario
#: (about a 23-bit converter): enough to make the unfiltered indicator chatter near the switching
#: surfaces, since the auxiliary states are up to (n-1)-fold differences of y.
TRADEOFF_NOISE_REL = 1e-7

#: Filter time constants of the trade-off, in samples (``None``: no filter).
TRADEOFF_FILTER_STEPS = (None, 5, 20, 100)


def filter_tradeoff(
    name: str,
    *,
    noise_levels: tuple[float, ...] = (0.0, TRADEOFF_NOISE_REL),
    filter_steps: tuple[int | None, ...] = TRADEOFF_FILTER_STEPS,
    base: ScenarioResult | None = None,
    seed: int = 0,
    results: dict | None = None,
) -> list[dict[str, Any]]:
    """Measure the delay-versus-chattering trade-off of the indicator filter (Figs. 5-6, 9 of paper 001).

    For each relative noise level (times the output's range) and each filter time constant (in
    samples), run observer (5) on the same plant trajectory and report the spurious switches of
    ``S_o``, its delay after the true switches, the mismatch fraction and window, and the error of
    the last canonical state (the one the wrong mode hurts first).

    Parameters
    ----------
    name : str
        A scenario of :data:`SCENARIOS`.
    noise_levels : tuple of float
        Noise standard deviations as fractions of the output's range.
    filter_steps : tuple of int or None
        Filter time constants in samples (``None``: no filter).
    base : ScenarioResult, optional
        A noise-free run whose plant trajectory and canonical form are reused.
    seed : int
    results : dict, optional
        If given, filled with the runs, keyed by ``(noise_level, filter_steps)``.

    Returns
    -------
    list of dict
        One row per (noise, filter) pair.
    """
    base = base if base is not None else run_scenario(name)
    Ts = base.observer.Ts
    y_range = float(np.ptp(base.truth.y[:, 0]))
    rows = []
    for rel in noise_levels:
        for steps in filter_steps:
            tau = None if steps is None else steps * Ts
            r = run_scenario(name, filter_tau=tau, noise=rel * y_range, seed=seed, truth=base.truth, form=base.form)
            if results is not None:
                results[(rel, steps)] = r
            ind = r.indicator
            rows.append({
                "example": name, "noise_rel": rel, "noise": rel * y_range, "filter_steps": steps, "filter_tau": tau,
                "spurious_switches": ind.spurious_switches, "true_switches": ind.true_switches,
                "missed_switches": ind.missed_switches, "delay_median_s": _json_float(ind.delay_median),
                "delay_max_s": _json_float(ind.delay_max), "mismatch_fraction": ind.mismatch_fraction,
                "window_s": _json_float(ind.window), "last_state_error": float(r.final_error[-1]),
            })
    return rows


def _plot(result: ScenarioResult, path: str, filtered: ScenarioResult | None = None) -> None:
    from hybobs_opt.plotting import pyplot

    plt = pyplot()

    n = result.form.n
    t = result.t
    fig, axes = plt.subplots(n + 1, 1, figsize=(7.5, 1.7 * (n + 1) + 0.6), sharex=True)
    for j in range(n):
        axes[j].plot(t, result.z_true[:, j], lw=1.2, label="true")
        axes[j].plot(t, result.run.z_hat[:, j], "--", lw=1.0, label="estimate")
        if np.isfinite(result.conv_times[j]):
            axes[j].axvline(result.conv_times[j], color="k", lw=0.6, alpha=0.5)
        axes[j].set_ylabel(result.form.names[j])
        axes[j].grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[n].step(t, result.S, where="post", lw=1.2, label="S")
    axes[n].step(t, result.run.mode, where="post", lw=0.8, label="S_o")
    if filtered is not None:
        axes[n].step(t, filtered.run.mode + 0.1, where="post", lw=0.8, label="S_o (filtered)")
    axes[n].legend(fontsize=7, loc="upper right")
    axes[n].set_ylabel("indicator S")
    axes[n].set_xlabel("t [s]")
    fig.suptitle(f"{result.spec.name}: sliding-mode observer (paper 001, eq. 5)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _cli_scenario(name: str):
    def scenario(args) -> dict[str, Any]:
        kind = getattr(args, "observer", None)
        if kind not in (None, "sliding-mode", "sliding_mode", "smo"):
            raise ModelError("--observers", "sliding-mode (the observer of paper 001 for this example)", repr(kind))
        res = run_scenario(name)
        out = summarize(res)
        filt = None
        if getattr(args, "filter", False):
            filt = run_scenario(name, filter_tau="default", truth=res.truth, form=res.form)
            out["filtered"] = summarize(filt)
        if getattr(args, "plot", None):
            _plot(res, args.plot, filt)
            out["plot"] = args.plot
        return out

    return scenario


def register_scenarios(register) -> None:
    """``hybobs observe triangular / double_scroll / switched_unstable``."""
    for name in ("triangular", "double_scroll", "switched_unstable"):
        register(name, _cli_scenario(name))
