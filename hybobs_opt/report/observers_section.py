"""Report section: the lookup-table observer against the MIQP/MILP moving-horizon observers
(paper 002, Section 7, Figs. 7-9), on noise-free and on noisy data."""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path

from ..studies.paper002_powertrain.bench import run_bench
from ..defaults import MHE_UNIQUENESS_DELTA
from .section import ReportSection, register_section, samples
from .text import num, yes_no

#: Steps of the scenario (1 ms each) and of the MHE runs (they cost milliseconds per step).
STEPS, MHE_STEPS = 3000, 3000
NOISY_STEPS, NOISE = 1500, 0.01

#: Observers of the noise study shown in the report (the MIQP without a prior is in the table
#: above and, on all three noise levels, in ``benchmarks/results/noise.json``); the MIQP with the
#: Kalman arrival cost runs on the first NOISE_STUDY_MHE_STEPS samples (through the first switch
#: of contact at sample 1,014; all 3,000 in the benchmark).
NOISE_STUDY_OBSERVERS = ("lookup", "lookup-noise", "miqp-kalman", "kalman")
NOISE_STUDY_MHE_STEPS = 1100

#: Hidden gaps of the unknown-gap subsection and the bank's grid spacing (ten gaps on a grid of
#: 0.002 rad in ``benchmarks/results/unknown_gap.json``); samples and noise-aware horizons of the
#: noise study (3,000 samples, T = 4 and 6 there): the report is built in the test suite.
GAP_DRAWS, GAP_REPORT_GRID_STEP = 2, 0.004
NOISE_STUDY_STEPS, NOISE_STUDY_HORIZONS = 1500, (4,)

#: Noise bound [rad/s] and samples of the radius subsection (model (16): at 0.01 rad/s no window of
#: three samples pins the load speed, and every observer says so).
RADIUS_BOUND, RADIUS_STEPS = 1e-3, 1200


def _noise_table(table: dict) -> str:
    rows = []
    names = table["state_names"]
    for level in table["levels"]:
        for name, r in level["observers"].items():
            f = r["flags"]
            rms = r["rms_error_flagged_observable"] or {}
            worst = r["max_abs_error_flagged_observable"] or {}
            rows.append(
                f"<tr><td>{num(level['noise'])}</td><td>{html.escape(name)}</td><td>{r.get('horizon', 3)}</td>"
                + _flags(f['observable'], f['unobservable'], f['fallback'])
                + "".join(f"<td>{_fmt(rms.get(nm))}</td>" for nm in names)
                + f"<td>{_fmt(worst.get('omega_l'))}</td><td>{_fmt(r.get('max_mahalanobis_flagged'))}</td>"
                f"<td>{r.get('n_flagged_beyond_5_sigma', 'n/a')}</td><td>{_ms(r['median_step_s'])}</td></tr>")
    head = ("<tr><th>noise sigma [rad/s]</th><th>observer</th><th>T [samples]</th>" + _FLAG_HEADS
            + "".join(f"<th>RMS {html.escape(nm)} error where flagged [{_UNITS[nm]}]</th>" for nm in names)
            + "<th>max |omega_l error| where flagged [rad/s]</th><th>max Mahalanobis distance where flagged</th>"
            "<th>flagged beyond 5 sigma [samples]</th><th>median step [ms]</th></tr>")
    return "<table>" + head + "".join(rows) + "</table>"


#: Units of model (16)'s states (paper 002, Section 5.1), for the column headers.
_UNITS = {"theta": "rad", "omega_m": "rad/s", "omega_l": "rad/s"}

#: Header of the flag counts: the samples an observer flagged observable, unobservable, or fell back on.
_FLAG_HEADS = "<th>flagged observable / unobservable / fallback [samples]</th>"


def _flags(observable, unobservable, fallback) -> str:
    """The cell under :data:`_FLAG_HEADS`."""
    return f"<td>{observable} / {unobservable} / {fallback}</td>"


def _ms(v) -> str:
    """A time in seconds written in ms, 4 significant digits."""
    return "n/a" if v is None else num(1e3 * v)


def _fmt(v) -> str:
    return num(v)


def _table(summary: dict) -> str:
    rows = []
    for name, r in summary["observers"].items():
        rows.append(
            f"<tr><td>{name}</td><td>{html.escape(str(r['solver']))}</td><td>{r['n_steps']}</td>"
            f"<td>{_ms(r['median_step_s'])} / {_ms(r['p95_step_s'])} / {_ms(r['max_step_s'])}</td>"
            f"<td>{_fmt(r.get('ratio_to_lookup'))}</td><td>{_fmt(r['max_abs_error_observable_all'])}</td>"
            + _flags(r['n_flagged_observable'], r['n_flagged_unobservable'], r['n_fallback'])
            + f"<td>{_fmt(r.get('rms_error_theta_unobservable_intervals'))}</td>"
            f"<td>{_fmt(r.get('rms_error_omega_l_unobservable_intervals'))}</td></tr>"
        )
    return ("<table><tr><th>observer</th><th>solver</th><th>steps [samples]</th><th>step median / p95 / max [ms]</th>"
            "<th>median step / lookup's</th>"
            "<th>max relative error where flagged observable</th>" + _FLAG_HEADS
            + "<th>RMS theta error, unobservable windows [rad]</th>"
            "<th>RMS omega_l error, unobservable windows [rad/s]</th></tr>" + "".join(rows) + "</table>")


def _noisy_note(square: bool) -> str:
    """What the noisy run shows (the bench's own note, in words for the report); ``square``: T p = n."""
    return ("<p>With output noise the lookup observer's consistency test (eq. 12) can reject a noisy window only "
            "when T p &gt; n; "
            + ("here T p = n, so every window fits some region exactly and the noise reaches the estimate through "
               "the inverse of C_i (the column of relative errors). " if square else "")
            + "Windows pushed out of every region leave no candidate and the observer predicts open loop (flagged "
            "unobservable or fallback); the moving-horizon observers return a least-error estimate instead. The MIQP "
            "is told the noise level: it flags a window observable only when the 99.9 % confidence region of its "
            "start state lies within delta; the MILPs' uniqueness test keeps its noise-free epsilon. The noise-aware "
            "lookup observer is compared in the noise study below.</p>")


def _alt(summary: dict, steps: int, noise: float) -> str:
    """What the figure of :func:`~hybobs_opt.studies.paper002_powertrain.bench.plot_bench` shows, from the run's summary."""
    obs = summary["observers"]
    flagged = ", ".join(f"{k} {r['n_flagged_observable']} of {r['n_steps']}" for k, r in obs.items())
    return (f"True theta [rad] with the backlash band and omega_l [rad/s] over {steps / 1000:g} s"
            + (f" (output noise sigma = {noise:g} rad/s)" if noise else "")
            + f", then the absolute estimation errors of theta [rad] and omega_l [rad/s] of the {', '.join(obs)} observers "
            f"on a log scale, each with its observability flag (observable / not observable) on a separate axis; "
            f"steps flagged observable: {flagged}")


def observers_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    # the quick preview still runs through the first change of contact (sample 1,014)
    steps, mhe_steps = samples(STEPS, 1200), samples(MHE_STEPS, 1200)
    noisy_steps = samples(NOISY_STEPS, 600)
    study_steps, study_mhe_steps = samples(NOISE_STUDY_STEPS, 1200), samples(NOISE_STUDY_MHE_STEPS, 120)
    gap_draws = samples(GAP_DRAWS, 1)
    progress("observers/noise-free")
    clean = run_bench("powertrain3", 3, steps, 0.0, ["lookup", "miqp", "milp"], mhe_steps=mhe_steps,
                      plot=str(out / "observers_fig7_9.png"))
    progress("observers/noisy")
    noisy = run_bench("powertrain3", 3, noisy_steps, NOISE, ["lookup", "miqp"], mhe_steps=mhe_steps,
                      plot=str(out / "observers_noisy.png"))
    lk = clean["observers"]["lookup"]
    body = [
        "<p>Model (16), T = 3, the torque profile of the scenario (the shaft crosses the backlash), "
        f"{steps} samples, every observer on all of them (each moving-horizon step is a mixed-integer "
        "program). The paper reports 3 s per MIQP step and 31 ms per lookup step (Matlab, Pentium 4).</p>",
        _table(clean),
        f"<p>Lookup batch throughput: {lk.get('batch_steps_per_s', 0):,.0f} steps/s "
        f"(the step-by-step and batch paths give identical flags: {yes_no(lk.get('batch_equals_steps'))}). "
        f"Share of windows whose window-start state is observable (exact point queries of Definition 2.2 on "
        f"{clean['truly_observable_windows_classified']} evenly spaced windows): {num(clean['truly_observable_fraction'])} "
        f"(95 % interval {num(clean['truly_observable_fraction_ci95'][0])}-{num(clean['truly_observable_fraction_ci95'][1])}); "
        f"windows whose true mode sequence has a full-rank output map (necessary only): "
        f"{num(clean['full_rank_sequence_fraction'])}. "
        "In unobservable windows the lookup observer predicts open loop from its last reconstruction and says so "
        "(exact here: no model error). The MIQP/MILP observers are warm-started with the previous trajectory shifted "
        "by one sample; on noise-free data that continuation is one of the zero-cost minimisers. A minimiser alone "
        "cannot tell whether it is unique (the paper's Fig. 8: a cold-started solve may return any other state with "
        "the same outputs), so after each optimum a second mixed-integer program searches for a window-start state "
        f"at least {num(MHE_UNIQUENESS_DELTA)} away (in the states scaled by their bounds) within epsilon of the optimal "
        "cost: 'observable' means it proved there is none; 'unobservable' means it found one (and returns it with the "
        "estimate).</p>",
        "<p>The figure: errors on a log scale (an exact estimate is drawn at the floor 1e-16); below each observer's "
        "errors, its flag on a separate axis, the observable steps shaded green.</p>",
        f"<img src='observers_fig7_9.png' alt='{html.escape(_alt(clean, steps, 0.0), quote=True)}'>",
        f"<h3>With output noise (sigma = {NOISE} rad/s)</h3>",
        _table(noisy),
        _noisy_note("here T p = n" in noisy.get("note", "")),
        f"<img src='observers_noisy.png' alt='{html.escape(_alt(noisy, noisy_steps, NOISE), quote=True)}'>",
    ]
    progress("observers/noise study")
    from ..studies.paper002_powertrain.noise import NOISE_LEVELS, run_noise_study
    from ..studies.paper002_powertrain.plots import plot_noise_errors

    traces: dict = {}
    study = run_noise_study("powertrain3", NOISE_LEVELS, study_steps, observers=NOISE_STUDY_OBSERVERS,
                            lookup_horizons=NOISE_STUDY_HORIZONS, traces=traces, mhe_steps=study_mhe_steps)
    plot_noise_errors(traces["truth"], {name: out for key, out in traces.items() if key != "truth" and key[0] == NOISE
                                        for name in [key[1]]}, out / "observers_noise_study.png", NOISE)
    body += [
        "<h3>Noise-aware lookup observers against a Kalman filter</h3>",
        "<p>The paper assumes noise-free outputs (Section 8). The noise-aware lookup observer "
        "(<code>NoiseAwareLookupObserver</code>) tests every mode sequence of a window longer than n/p with a "
        "chi-square residual test and region membership with per-row margins at a stated false-alarm probability "
        "(1e-3), and flags a window observable only when exactly one full-rank sequence passes; its estimate "
        "carries the covariance of the weighted least-squares error. The moving-horizon MIQP with the arrival cost "
        "tuned from the noise level (<code>MHEObserver(noise_std=sigma, arrival_weight='kalman')</code>, T = 3) "
        "takes as each window's prior a Kalman filter's prediction from the samples before the window, in the mode "
        f"sequence the windows estimated, weighted by its inverse covariance (first {study_mhe_steps} samples); "
        "its flag means unique given that prior, and its estimates state their posterior covariance. The Kalman filter "
        "is told the true mode sequence: the unattainable reference. Same scenario, "
        f"{study_steps} samples (the noise benchmark, <code>python -m benchmarks.bench_noise</code>, runs 3,000, "
        "also at T = 6 and with the MIQP), noise on the engine speed.</p>",
        _noise_table(study),
        "<p>The RMS errors are over the samples each observer flags observable; the Mahalanobis distance uses the "
        "stated covariance of each flagged estimate (the paper's lookup states none). What the noise-aware flag "
        "proves: every other mode sequence of the model was rejected at the stated false-alarm probability; the "
        "covariance is that of the error if the passing sequence is the true one. At 0.1 rad/s windows of 4 "
        "samples (1 ms each) cannot tell the modes apart: the noise-aware observer says so rather than guessing.</p>",
        f"<img src='observers_noise_study.png' alt='{html.escape(_noise_alt(study, NOISE), quote=True)}'>",
    ]
    progress("observers/unknown gap")
    from ..studies.paper002_powertrain.plots import plot_gap_estimates
    from ..studies.paper002_powertrain.unknown_gap import run_unknown_gap_study

    gap_runs: list = []
    gap = run_unknown_gap_study(gap_draws, steps, grid_step=GAP_REPORT_GRID_STEP, traces=gap_runs)
    plot_gap_estimates(gap_runs[0][0], [(a, e) for _, a, e in gap_runs], out / "observers_unknown_gap.png")
    body += [
        "<h3>The backlash gap hidden from the observer</h3>",
        f"<p>{gap_draws} gaps drawn in [0.02, 0.08] rad (the twist bound widened to "
        f"{gap['theta_max']:g} rad: the scenario twists the shaft beyond 0.2 rad when alpha &gt; 0.055); a bank of "
        f"{gap['grid']['n']} lookup observers over the interval (<code>ParameterBank</code>), scored by the jump between "
        "each one's prediction and its next reconstruction, estimates the gap; the state estimate comes from a lookup "
        "observer built at the estimate. A window of T samples cannot tell the gap (inside a contact mode the outputs "
        "depend on theta - alpha only); a whole traversal of the gap does, and the bank remembers it.</p>",
        _gap_table(gap),
        f"<img src='observers_unknown_gap.png' alt='{html.escape(_gap_alt(gap), quote=True)}'>",
    ]
    progress("observers/radii")
    from ..studies.paper002_powertrain.radii import run_radius_study
    from .plots import plot_radii

    radius_runs: dict = {}
    radii = run_radius_study(RADIUS_BOUND, samples(RADIUS_STEPS, 300), traces=radius_runs)
    truth = radius_runs.pop("truth")
    plot_radii(truth.t, truth.x, radius_runs, out / "observers_radii.png",
               title=f"Certified radii and true errors, |noise| <= {RADIUS_BOUND:g} rad/s",
               state_names=radii["state_names"], units=("rad", "rad/s", "rad/s"))
    body += [
        "<h3>Certified radii under bounded noise</h3>",
        f"<p>The same scenario with uniform noise on the engine speed, |noise| &lt;= {RADIUS_BOUND:g} rad/s, stated to "
        f"the observers as a bound (<code>noise_bound</code>), T = {radii['horizon']}, {radii['steps']} samples. Each "
        "estimate carries a radius per state: every state consistent with the window's data under the bound and the "
        "model lies within it, so the true state does whenever the data satisfy the bound. "
        "<code>set_membership</code> computes the exact box of those states (MILPs solved to a zero gap) and reports "
        "its centre; <code>miqp_bounded</code> is the MIQP moving-horizon observer with the same box around its "
        "optimum; <code>lookup_bounded</code> widens each lookup piece by the noise amplified through its inverse map "
        "(an outer box, one table product per step). A step is flagged observable when every radius is within "
        f"{num(MHE_UNIQUENESS_DELTA)} of the half-width of its state bound. The speed of the load is seen only through "
        "differences of 1 ms samples: its radius is the noise amplified about a thousand times.</p>",
        _radius_table(radii),
        f"<img src='observers_radii.png' alt='{html.escape(_radius_alt(radii), quote=True)}'>",
    ]
    summary = {"noise_free": clean, "noisy": noisy, "noise_study": study, "unknown_gap": gap, "radii": radii}
    return ReportSection("Lookup vs MIQP/MILP moving-horizon observers (paper 002, Section 7)", "\n".join(body), summary,
                         ["observers_fig7_9.png", "observers_noisy.png", "observers_noise_study.png",
                          "observers_unknown_gap.png", "observers_radii.png"])


def _radius_table(radii: dict) -> str:
    names = radii["state_names"]
    rows = []
    for name, r in radii["observers"].items():
        f = r["flags"]
        med = r["radius_median"] or {}
        worst = r["max_abs_error_flagged"] or {}
        rows.append(f"<tr><td>{html.escape(name)}</td>" + _flags(f['observable'], f['unobservable'], f['fallback'])
                    + f"<td>{r['n_outside_radius']}</td>"
                    + "".join(f"<td>{_fmt(med.get(nm))}</td>" for nm in names)
                    + "".join(f"<td>{_fmt(worst.get(nm))}</td>" for nm in names)
                    + f"<td>{_ms(r['median_step_s'])}</td></tr>")
    head = ("<tr><th>observer</th>" + _FLAG_HEADS + "<th>true state outside the radius [samples]</th>"
            + "".join(f"<th>median radius of {html.escape(nm)} [{_UNITS[nm]}]</th>" for nm in names)
            + "".join(f"<th>max |{html.escape(nm)} error| where flagged [{_UNITS[nm]}]</th>" for nm in names)
            + "<th>median step [ms]</th></tr>")
    return "<table>" + head + "".join(rows) + "</table>"


def _radius_alt(radii: dict) -> str:
    parts = [f"{name}: {r['n_outside_radius']} of {r['n_with_radius']} true states outside the radius, "
             f"{r['flags']['observable']} steps flagged observable" for name, r in radii["observers"].items()]
    return (f"One panel per state ({', '.join(radii['state_names'])}) over t [s], log scale: each observer's certified "
            f"radius as a line and its actual error as dots, noise bound {radii['bound']:g} rad/s; " + "; ".join(parts))


def _gap_table(gap: dict) -> str:
    rows = []
    for d in gap["draws"]:
        err = d["bank_max_abs_error_flagged"] or {}
        rows.append(f"<tr><td>{num(d['alpha'])}</td><td>{num(d['first_crossing_sample'])}</td>"
                    f"<td>{num(d['determined_from_sample'])}</td><td>{_fmt(d['estimate_after_first_crossing'])}</td>"
                    f"<td>{_fmt(d['max_relative_error_after_first_crossing'])}</td>"
                    f"<td>{d['bank_flags']['observable']}</td><td>{d['known_gap_flags']['observable']}</td>"
                    f"<td>{_fmt(err.get('theta'))}</td><td>{_fmt(err.get('omega_l'))}</td></tr>")
    return ("<table><tr><th>hidden alpha [rad]</th><th>first crossing [sample]</th><th>determined from [sample]</th>"
            "<th>estimate after it [rad]</th><th>largest relative error after it</th>"
            "<th>flagged observable, bank [samples]</th><th>flagged observable, alpha known [samples]</th><th>max |theta error| where flagged [rad]</th>"
            "<th>max |omega_l error| where flagged [rad/s]</th></tr>" + "".join(rows) + "</table>")


def _gap_alt(gap: dict) -> str:
    parts = [f"hidden {d['alpha']:.4f} rad, largest relative error after the first crossing "
             f"{num(d['max_relative_error_after_first_crossing'], 2)}" for d in gap["draws"]]
    return ("The bank's gap estimate [rad] over t [s] beside each hidden gap (dashed), and its relative error on a log "
            "scale against the 5 % line: " + "; ".join(parts))


def _noise_alt(study: dict, sigma: float) -> str:
    """What :func:`~hybobs_opt.studies.paper002_powertrain.plots.plot_noise_errors` shows, from the study's table."""
    level = next(lv for lv in study["levels"] if lv["noise"] == sigma)
    parts = []
    for name, r in level["observers"].items():
        worst = (r["max_abs_error_flagged_observable"] or {}).get("omega_l")
        parts.append(f"{name}: {r['flags']['observable']} samples flagged observable, largest |omega_l error| "
                     + ("n/a" if worst is None else f"{worst:.3g} rad/s")
                     + ("" if r.get("max_mahalanobis_flagged") is None
                        else f", {'inside' if r['max_mahalanobis_flagged'] <= 5.0 else 'NOT inside'} its band of 5 "
                             f"standard deviations of the stated covariance (largest Mahalanobis distance "
                             f"{r['max_mahalanobis_flagged']:.2f})"))
    return (f"Signed omega_l errors [rad/s] over t [s] at the samples each observer flags observable, output noise "
            f"sigma = {sigma:g} rad/s, one axis per observer: " + "; ".join(parts))


register_section("observers", observers_section)
