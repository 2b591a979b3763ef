"""Plots of observer runs (true states against estimates, errors, the scheduling region)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from ..plotting import pyplot, quantity_label, save_figure

plt = pyplot()
import numpy as np  # noqa: E402


def plot_observer_run(trace, runs: Sequence, path: str | Path, title: str = "", labels: Sequence[str] | None = None,
                      max_states: int = 4, units: Sequence[str] | Mapping[str, str] | None = None) -> Path:
    """True states against the estimates of one or more observer runs, errors, and the region.

    Parameters
    ----------
    trace : Trace
        The true run (``trace.x``, ``trace.t``).
    runs : sequence
        Observer runs with ``x_hat`` (aligned with ``trace``) and ``mode`` (the region index).
    path : path-like
        Output file (PNG).
    title : str
    labels : sequence of str, optional
        One legend entry per run (default: ``run.observer``).
    max_states : int
        Plot at most this many states.
    units : sequence or mapping of str, optional
        The unit of each state (aligned with ``trace.state_names`` or ``{name: unit}``), shown on
        its axes; a state without one is labelled with its name only.

    Returns
    -------
    Path
        The file written.

    See Also
    --------
    ObserverTrace : The runs it draws.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import plot_observer_run
    >>> run = LookupObserver(analysis).run(U, truth.y)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = plot_observer_run(truth, [run], Path(tmp) / "run.png", labels=["lookup"])
    ...     print(path.name, path.stat().st_size > 0)
    ...
    run.png True
    """
    path = Path(path)
    n = min(trace.x.shape[1], max_states)
    if isinstance(units, Mapping):
        unit = [str(units.get(nm, "") or "") for nm in trace.state_names]
    else:
        unit = [str(u or "") for u in (units or ())] + [""] * trace.x.shape[1]
    labels = list(labels or [r.observer for r in runs])
    fig, axes = plt.subplots(n + 1, 2, figsize=(10, 1.7 * (n + 1) + 0.6), sharex=True, squeeze=False)
    for i in range(n):
        axes[i, 0].plot(trace.t, trace.x[:, i], color="k", lw=1.2, label="true")
        for j, r in enumerate(runs):
            axes[i, 0].plot(trace.t, r.x_hat[:, i], lw=0.9, ls="--", color=f"C{j}", label=labels[j])
            axes[i, 1].plot(trace.t, r.x_hat[:, i] - trace.x[:, i], lw=0.9, color=f"C{j}")
        axes[i, 0].set_ylabel(quantity_label(trace.state_names[i], unit[i]))
        axes[i, 1].set_ylabel(quantity_label(f"error {trace.state_names[i]}", unit[i]))
        for a in axes[i]:
            a.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    for j, r in enumerate(runs):
        axes[n, 0].step(trace.t, r.mode, where="post", color=f"C{j}", lw=1)
    axes[n, 0].set_ylabel("region index")
    err = [np.linalg.norm(r.x_hat - trace.x, axis=1) for r in runs]
    for j, e in enumerate(err):
        axes[n, 1].semilogy(trace.t, np.maximum(e, 1e-12), color=f"C{j}", lw=0.9)
    axes[n, 1].set_ylabel("|error| (2-norm,\nmixed units)" if any(unit[:trace.x.shape[1]]) else "|error| (2-norm)")
    for a in axes[n]:
        a.set_xlabel("t [s]")
        a.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=100)


# ---------------------------------------------------------------------------- diagnose report
