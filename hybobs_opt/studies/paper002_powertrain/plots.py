"""The figure of the observer comparison of paper 002, Section 7 (Figs. 7-9).

Drawn by :func:`hybobs_opt.studies.paper002_powertrain.bench.plot_bench` (``hybobs observe
powertrain3 --plot``, the report's observers section): the true twist angle and wheel speed, then
for each observer the absolute estimation errors of both on a log scale and, on its own thin axis
below them, the observability flag of every step.  Every axis names its quantity and unit
(paper 002, Section 5.1: angles in rad, speeds in rad/s).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hybobs_opt.contract import OBSERVABLE

#: Smallest error drawn on the log axes (an exact estimate would have no point on them).
ERROR_FLOOR = 1e-16

#: Colour of the "observable" steps on the flag axes, and its word in the report's text.
FLAG_COLOUR = ("green", "tab:green")


def state_unit(name: str) -> str:
    """The unit of a state of models (16) and (17): ``"rad"`` for an angle ``theta*``, ``"rad/s"`` for a speed ``omega*``.

    Parameters
    ----------
    name : str
        A state name of :func:`~hybobs_opt.studies.paper002_powertrain.systems.powertrain3` or
        :func:`~hybobs_opt.studies.paper002_powertrain.systems.powertrain5`.

    Returns
    -------
    str
        ``""`` for any other name.
    """
    return "rad" if name.startswith("theta") else "rad/s" if name.startswith("omega") else ""


def plotted_states(state_names) -> tuple[str, str]:
    """The two states the figure shows: the backlash angle (``theta``; ``theta_cl`` in model 17) and ``omega_l``.

    Parameters
    ----------
    state_names : sequence of str

    Returns
    -------
    (str, str)
    """
    names = list(state_names)
    angle = next((s for s in ("theta", "theta_cl", "theta_mc") if s in names), names[0])
    speed = "omega_l" if "omega_l" in names else names[-1]
    return angle, speed


def plot_observer_errors(trace, outs: Mapping, path: str | Path, backlash: float | None = None) -> str:
    """Save the Figs. 7-9 panel of paper 002: states, each observer's errors and its flags.

    Parameters
    ----------
    trace : Trace
        The plant's run (``t``, ``x``, ``state_names``).
    outs : mapping
        ``{observer name: ObserverTrace}``; each trace may be shorter than ``trace`` (the MHE runs).
    path : path-like
        Output file (PNG).
    backlash : float, optional
        Half-width ``alpha`` of the backlash band, shaded on the angle axis when given (rad).

    Returns
    -------
    str
        ``path``.
    """
    from hybobs_opt.plotting import pyplot, quantity_label

    plt = pyplot()
    t = trace.t
    angle, speed = plotted_states(trace.state_names)
    cols = [trace.state_names.index(angle), trace.state_names.index(speed)]
    names = list(outs)
    ratios = [1.6] + [1.3, 0.45] * len(names)
    fig = plt.figure(figsize=(10, 1.6 + 1.9 * len(names) + 0.9))
    gs = fig.add_gridspec(len(ratios), 2, height_ratios=ratios, hspace=0.38, wspace=0.42)
    first = fig.add_subplot(gs[0, 0])
    top = [first, fig.add_subplot(gs[0, 1], sharex=first)]
    bottom = top
    for c, (name, i) in enumerate(zip((angle, speed), cols)):
        ax = top[c]
        ax.plot(t, trace.x[:, i], color="k", lw=1.1, label=f"true {name}")
        if backlash is not None and c == 0:
            ax.axhspan(-backlash, backlash, color="0.85", label=f"backlash band |{name}| < {backlash:g} rad")
        ax.set_ylabel(quantity_label(name, state_unit(name)))
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, frameon=False, borderaxespad=0.1)
        ax.grid(alpha=0.3)
    for k, obs in enumerate(names):
        out = outs[obs]
        n = out.n_steps
        flag = (np.asarray(out.flags[:n]) == OBSERVABLE).astype(float)
        bottom = []
        for c, (name, i) in enumerate(zip((angle, speed), cols)):
            ax = fig.add_subplot(gs[1 + 2 * k, c], sharex=first)
            e = np.abs(out.x_hat[:n, i] - trace.x[:n, i])
            ax.semilogy(t[:n], np.maximum(e, ERROR_FLOOR), color=f"C{k}", lw=0.9)
            ax.set_ylabel(quantity_label(f"|error {name}|", state_unit(name)), fontsize=8)
            ax.set_title(f"{obs} observer", loc="left", fontsize=8, pad=2)
            ax.grid(alpha=0.3)
            # the step's flag on its own thin axis under the errors, on the same time axis
            fax = fig.add_subplot(gs[2 + 2 * k, c], sharex=first)
            fax.fill_between(t[:n], 0.0, flag, step="post", color=FLAG_COLOUR[1], alpha=0.35, lw=0)
            fax.step(t[:n], flag, where="post", color="k", lw=0.7)
            fax.set_ylim(-0.2, 1.2)
            fax.set_yticks([0, 1])
            fax.set_yticklabels(["not observable", "observable"], fontsize=7)
            fax.set_ylabel("flag", fontsize=8)
            bottom.append(fax)
    if not names:
        bottom = top
    for ax in fig.axes:
        ax.tick_params(axis="x", labelbottom=ax in bottom)
    for ax in bottom:
        ax.set_xlabel("t [s]")
    fig.suptitle("Paper 002, Figs. 7-9: errors on a log scale (floored at "
                 f"{ERROR_FLOOR:g}) and the observability flag of each observer", fontsize=10)
    fig.subplots_adjust(left=0.12, right=0.98, top=1 - 0.6 / fig.get_figheight(), bottom=0.5 / fig.get_figheight())
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)



def plot_noise_errors(trace, outs: Mapping, path: str | Path, sigma: float, state: str = "omega_l",
                      sigmas: float = 5.0) -> str:
    """Save the noise study's figure: one state's error where each observer flags ``observable``.

    One axis per observer, over time: the signed error of ``state`` at the samples the observer
    flags observable (dots), and for an observer whose ``Estimate.info`` states a covariance the
    band of ``sigmas`` standard deviations of that covariance around zero: an honest observer's
    dots stay inside its band (none beyond 5 sigma).  Drawn by the report's observers
    section for :func:`~hybobs_opt.studies.paper002_powertrain.noise.run_noise_study`.

    Parameters
    ----------
    trace : Trace
        The plant's run (``t``, ``x``, ``state_names``).
    outs : mapping
        ``{observer name: ObserverTrace}``.
    path : path-like
        Output file (PNG).
    sigma : float
        The output noise of the run (rad/s), for the title.
    state : str, default "omega_l"
        The state drawn.
    sigmas : float, default 5.0
        Width of the covariance band in standard deviations.

    Returns
    -------
    str
        ``path``.
    """
    from hybobs_opt.plotting import pyplot, quantity_label

    plt = pyplot()
    i = trace.state_names.index(state)
    t = trace.t
    names = list(outs)
    fig, axes = plt.subplots(len(names), 1, figsize=(10, 1.2 + 1.9 * len(names)), sharex=True, squeeze=False)
    for k, (ax, name) in enumerate(zip(axes[:, 0], names)):
        out = outs[name]
        n = out.n_steps
        flagged = np.nonzero(np.asarray(out.flags[:n]) == OBSERVABLE)[0]
        e = out.x_hat[:n, i] - trace.x[:n, i]
        covs = [out.info[j].get("covariance") if j < len(out.info) else None for j in flagged]
        if flagged.size and all(c is not None for c in covs):
            band = np.full(n, np.nan)
            band[flagged] = [sigmas * np.sqrt(max(np.asarray(c, dtype=float)[i, i], 0.0)) for c in covs]
            ax.fill_between(t[:n], -band, band, color=f"C{k}", alpha=0.2, lw=0,
                            label=f"{sigmas:g} standard deviations of the stated covariance")
        ax.plot(t[flagged], e[flagged], ".", ms=2.5, color=f"C{k}",
                label=f"error where flagged observable ({flagged.size} of {n} samples)")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_title(f"{name} observer", loc="left", fontsize=8, pad=2)
        ax.set_ylabel(quantity_label(f"error {state}", state_unit(state)), fontsize=8)
        ax.legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2, frameon=False, borderaxespad=0.1)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"Paper 002 with output noise sigma = {sigma:g} rad/s: {state} errors of the estimates flagged observable",
                 fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def plot_gap_estimates(t, runs: list, path: str | Path) -> str:
    """Save the unknown-gap study's figure: each hidden gap and the bank's estimate over time.

    Parameters
    ----------
    t : (N,) array
        Sample times (s).
    runs : list of (alpha, estimate) pairs
        The hidden gap (rad) and the bank's estimate per sample (NaN while undetermined).
    path : path-like
        Output file (PNG).

    Returns
    -------
    str
        ``path``.
    """
    from hybobs_opt.plotting import pyplot, quantity_label

    plt = pyplot()
    fig, (ax, rel) = plt.subplots(2, 1, figsize=(10, 5.2), sharex=True)
    for k, (alpha, est) in enumerate(runs):
        ax.axhline(alpha, color=f"C{k}", lw=0.8, ls="--")
        ax.plot(t, est, color=f"C{k}", lw=1.4, label=f"hidden alpha = {alpha:.4f} rad (dashed), estimate (solid)")
        rel.semilogy(t, np.maximum(np.abs(est - alpha) / alpha, ERROR_FLOOR), color=f"C{k}", lw=1.0)
    rel.axhline(0.05, color="k", lw=0.8, ls=":", label="5 % (the issue's criterion)")
    ax.set_ylabel(quantity_label("alpha", "rad"))
    ax.legend(fontsize=7, loc="upper left", frameon=False)
    ax.grid(alpha=0.3)
    rel.set_ylabel("|estimate - alpha| / alpha")
    rel.set_xlabel("t [s]")
    rel.legend(fontsize=7, loc="upper right", frameon=False)
    rel.grid(alpha=0.3)
    fig.suptitle("Paper 002 with the backlash gap hidden: the bank's estimate (undetermined, not drawn, until the "
                 "shaft has crossed the gap)", fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)
