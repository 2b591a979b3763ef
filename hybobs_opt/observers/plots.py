"""Plots of observer runs (true states against estimates, errors, the scheduling region)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..plotting import pyplot, save_figure

plt = pyplot()
import numpy as np  # noqa: E402


def plot_observer_run(trace, runs: Sequence, path: str | Path, title: str = "", labels: Sequence[str] | None = None,
                      max_states: int = 4) -> Path:
    """True states against the estimates of one or more observer runs, errors, and the region."""
    path = Path(path)
    n = min(trace.x.shape[1], max_states)
    labels = list(labels or [r.observer for r in runs])
    fig, axes = plt.subplots(n + 1, 2, figsize=(10, 1.7 * (n + 1) + 0.6), sharex=True, squeeze=False)
    for i in range(n):
        axes[i, 0].plot(trace.t, trace.x[:, i], color="k", lw=1.2, label="true")
        for j, r in enumerate(runs):
            axes[i, 0].plot(trace.t, r.x_hat[:, i], lw=0.9, ls="--", color=f"C{j}", label=labels[j])
            axes[i, 1].plot(trace.t, r.x_hat[:, i] - trace.x[:, i], lw=0.9, color=f"C{j}")
        axes[i, 0].set_ylabel(trace.state_names[i])
        axes[i, 1].set_ylabel(f"error {trace.state_names[i]}")
        for a in axes[i]:
            a.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    for j, r in enumerate(runs):
        axes[n, 0].step(trace.t, r.mode, where="post", color=f"C{j}", lw=1)
    axes[n, 0].set_ylabel("region")
    err = [np.linalg.norm(r.x_hat - trace.x, axis=1) for r in runs]
    for j, e in enumerate(err):
        axes[n, 1].semilogy(trace.t, np.maximum(e, 1e-12), color=f"C{j}", lw=0.9)
    axes[n, 1].set_ylabel("|error|")
    for a in axes[n]:
        a.set_xlabel("t [s]")
        a.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=100)


# ---------------------------------------------------------------------------- diagnose report
