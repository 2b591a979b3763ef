"""Plots of simulation traces (matplotlib, Agg backend: no screen needed)."""

from __future__ import annotations

from pathlib import Path

from ..plotting import pyplot, save_figure

plt = pyplot()
import numpy as np  # noqa: E402

from ..sim.trace import Trace  # noqa: E402


def plot_trace(trace: Trace, path: str | Path, title: str = "", max_states: int = 6) -> Path:
    """Plot each state and the discrete state ``q`` against time and save a PNG.

    Parameters
    ----------
    trace : Trace
    path : path-like
        Output file (PNG).
    title : str
    max_states : int
        Plot at most this many states (one panel each).

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    n = min(trace.x.shape[1], max_states)
    fig, axes = plt.subplots(n + 1, 1, figsize=(7.5, 1.6 * (n + 1) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    for i in range(n):
        axes[i].plot(trace.t, trace.x[:, i], lw=1.0)
        axes[i].set_ylabel(trace.state_names[i], rotation=0, ha="right", va="center")
        axes[i].grid(alpha=0.3)
    axes[n].step(trace.t, trace.q, where="post", lw=1.0, color="tab:red")
    axes[n].set_ylabel("q", rotation=0, ha="right", va="center")
    if trace.location_names:
        ticks = sorted(set(int(v) for v in np.unique(trace.q)))
        axes[n].set_yticks(ticks)
        axes[n].set_yticklabels([trace.location_names[k] if k < len(trace.location_names) else str(k) for k in ticks], fontsize=7)
    axes[n].set_xlabel("t [s]")
    axes[n].grid(alpha=0.3)
    return save_figure(fig, path, title)


def plot_estimates(trace, log, path: str | Path, title: str = "", max_states: int = 6) -> Path:
    """An observer's run on a log: each estimated state (the true one too when the log has it),
    with the samples flagged ``observable`` marked, and the flags against the sample index."""
    path = Path(path)
    n = min(trace.x_hat.shape[1], max_states)
    k = np.arange(trace.n_steps) if log.t is None else log.t
    flagged = trace.flags == "observable"
    fig, axes = plt.subplots(n + 1, 1, figsize=(7.5, 1.6 * (n + 1) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    for i in range(n):
        if log.X is not None:
            axes[i].plot(k, log.X[:, i], lw=1.0, color="0.5", label="true")
        axes[i].plot(k, trace.x_hat[:, i], lw=0.9, color="tab:blue", label="estimate")
        axes[i].plot(k[flagged], trace.x_hat[flagged, i], ".", ms=2, color="tab:green", label="flagged observable")
        axes[i].set_ylabel(trace.state_names[i] if trace.state_names else f"x{i + 1}", rotation=0, ha="right", va="center")
        axes[i].grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    codes = {"observable": 3, "unobservable": 2, "warming_up": 1, "fallback": 0}
    axes[n].step(k, [codes.get(str(f), 0) for f in trace.flags], where="post", lw=1.0, color="tab:red")
    axes[n].set_yticks(sorted(codes.values()))
    axes[n].set_yticklabels(sorted(codes, key=codes.get), fontsize=7)
    axes[n].set_xlabel("t [s]" if log.t is not None else "sample")
    return save_figure(fig, path, title)
