"""Plots of simulation traces and region cuts (matplotlib, Agg backend: no screen needed).

Every axis carries its quantity and, when known, its unit (``"omega_m [rad/s]"``,
:func:`hybobs_opt.plotting.quantity_label`); a state without a declared unit is labelled with its
name only.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from ..plotting import pyplot, quantity_label, save_figure

plt = pyplot()
import numpy as np  # noqa: E402

from ..sim.trace import Trace  # noqa: E402


def _unit_list(names: Sequence[str], units: Sequence[str] | Mapping[str, str] | None) -> list[str]:
    """One unit per name (``""`` when unknown) from a sequence aligned with ``names`` or a mapping."""
    if not units:
        return [""] * len(names)
    if isinstance(units, Mapping):
        return [str(units.get(nm, "") or "") for nm in names]
    units = list(units)
    return [str(units[i] or "") if i < len(units) else "" for i in range(len(names))]


def plot_trace(trace: Trace, path: str | Path, title: str = "", max_states: int = 6,
               units: Sequence[str] | Mapping[str, str] | None = None) -> Path:
    """Plot each state and the discrete state ``q`` against time and save a PNG.

    Parameters
    ----------
    trace : Trace
    path : path-like
        Output file (PNG).
    title : str
    max_states : int
        Plot at most this many states (one panel each).
    units : sequence or mapping of str, optional
        The unit of each state (aligned with ``trace.state_names``, or ``{name: unit}``), shown
        on its axis as ``"name [unit]"``; a state without one is labelled with its name only.

    Returns
    -------
    Path
        The file written.

    See Also
    --------
    plot_region_cut : the report's figure of a cut.
    hybobs_opt.sim.Trace : what it draws.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.report import plot_trace
    >>> example = get_example("switching_server")
    >>> path = plot_trace(example.simulate(t_final=20.0), Path(tempfile.mkdtemp()) / "server.png",
    ...                   title=example.summary, units=example.state_units)
    >>> path.name, path.read_bytes()[1:4]
    ('server.png', b'PNG')
    """
    path = Path(path)
    n = min(trace.x.shape[1], max_states)
    unit = _unit_list(trace.state_names, units)
    fig, axes = plt.subplots(n + 1, 1, figsize=(7.5, 1.6 * (n + 1) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    for i in range(n):
        axes[i].plot(trace.t, trace.x[:, i], lw=1.0)
        axes[i].set_ylabel(quantity_label(trace.state_names[i], unit[i]))
        axes[i].grid(alpha=0.3)
    axes[n].step(trace.t, trace.q, where="post", lw=1.0, color="tab:red")
    axes[n].set_ylabel("location q")
    if trace.location_names:
        ticks = sorted(set(int(v) for v in np.unique(trace.q)))
        axes[n].set_yticks(ticks)
        axes[n].set_yticklabels([trace.location_names[k] if k < len(trace.location_names) else str(k) for k in ticks], fontsize=7)
    axes[n].set_xlabel("t [s]")
    axes[n].grid(alpha=0.3)
    return save_figure(fig, path, title)


def plot_estimates(trace, log, path: str | Path, title: str = "", max_states: int = 6,
                   units: Sequence[str] | Mapping[str, str] | None = None) -> Path:
    """An observer's run on a log: each estimated state (the true one too when the log has it),
    with the samples flagged ``observable`` marked, the certified radius as a band around the
    estimate when the observer states one (``info["radius"]``), and the flags on their own
    labelled axis.

    Parameters
    ----------
    trace : ObserverTrace
        The observer's estimates and flags.
    log : Log
        The log it ran on (``log.t`` and ``log.X`` when recorded).
    path : path-like
        Output file (PNG).
    title : str
    max_states : int
        Plot at most this many states (one panel each).
    units : sequence or mapping of str, optional
        The unit of each state, as for :func:`plot_trace` (none for a user system without units).

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    n = min(trace.x_hat.shape[1], max_states)
    k = np.arange(trace.n_steps) if log.t is None else log.t
    flagged = trace.flags == "observable"
    names = list(trace.state_names) if trace.state_names else [f"x{i + 1}" for i in range(trace.x_hat.shape[1])]
    unit = _unit_list(names, units)
    fig, axes = plt.subplots(n + 1, 1, figsize=(7.5, 1.6 * n + 1.4), sharex=True,
                             gridspec_kw={"height_ratios": [1.0] * n + [0.6]})
    axes = np.atleast_1d(axes)
    radii = trace.radii()
    for i in range(n):
        if radii is not None:
            axes[i].fill_between(k, trace.x_hat[:, i] - radii[:, i], trace.x_hat[:, i] + radii[:, i], color="tab:blue",
                                 alpha=0.2, lw=0, label="certified radius")
        if log.X is not None:
            axes[i].plot(k, log.X[:, i], lw=1.0, color="0.5", label="true")
        axes[i].plot(k, trace.x_hat[:, i], lw=0.9, color="tab:blue", label="estimate")
        axes[i].plot(k[flagged], trace.x_hat[flagged, i], ".", ms=2, color="tab:green", label="flagged observable")
        axes[i].set_ylabel(quantity_label(names[i], unit[i]))
        axes[i].grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    codes = {"observable": 3, "unobservable": 2, "warming_up": 1, "fallback": 0}
    axes[n].step(k, [codes.get(str(f), 0) for f in trace.flags], where="post", lw=1.0, color="tab:red")
    axes[n].set_yticks(sorted(codes.values()))
    axes[n].set_yticklabels(sorted(codes, key=codes.get), fontsize=7)
    axes[n].set_ylim(-0.5, 3.5)
    axes[n].set_ylabel("flag")
    axes[n].set_xlabel("t [s]" if log.t is not None else "sample")
    return save_figure(fig, path, title)


def plot_radii(t: np.ndarray, x_true: np.ndarray, runs: Mapping[str, object], path: str | Path, title: str = "",
               state_names: Sequence[str] = (), units: Sequence[str] | Mapping[str, str] | None = None) -> Path:
    """Certified radii against true errors: one panel per state, on a log scale, each observer's
    stated radius as a line and its actual error ``|x^ - x|`` as dots (a radius that holds stays
    above its dots).

    Parameters
    ----------
    t : (N,) array
        Sample times.
    x_true : (N, n) array
        The true states.
    runs : mapping of str to ObserverTrace
        The observers' runs (each stating ``info["radius"]``).
    path : path-like
        Output file (PNG).
    title : str
    state_names : sequence of str
    units : sequence or mapping of str, optional

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    n = x_true.shape[1]
    names = list(state_names) or [f"x{i + 1}" for i in range(n)]
    unit = _unit_list(names, units)
    fig, axes = plt.subplots(n, 1, figsize=(7.5, 1.9 * n + 0.8), sharex=True)
    axes = np.atleast_1d(axes)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    # observers that state the same radius draw on top of each other: wide solid, dashed, dotted
    styles = [("-", 2.4, "o", 2.4), ("--", 1.4, "x", 2.2), (":", 1.0, "+", 2.6)]
    floor = 1e-12
    for c, (name, run) in enumerate(runs.items()):
        R = run.radii()
        if R is None:
            continue
        err = np.abs(run.x_hat - x_true)
        colour = colours[c % len(colours)]
        ls, lw, marker, ms = styles[c % len(styles)]
        for i in range(n):
            axes[i].semilogy(t, np.maximum(R[:, i], floor), ls=ls, lw=lw, color=colour, label=f"{name}: radius")
            axes[i].semilogy(t, np.maximum(err[:, i], floor), marker, ls="none", ms=ms, mew=0.6, color=colour,
                             alpha=0.7, label=f"{name}: |error|")
    for i in range(n):
        axes[i].set_ylabel(quantity_label(names[i], unit[i]))
        axes[i].grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=6, loc="upper right", ncol=2)
    axes[-1].set_xlabel("t [s]")
    return save_figure(fig, path, title)


#: Colours of the region cuts, by label: (word used in the report's text, matplotlib colour).  The keys
#: are the values of :class:`~hybobs_opt.regions.PointClass` (a member looks its entry up), written as
#: strings so that importing this module does not import the regions package.
CUT_COLOURS: dict[str, tuple[str, str]] = {
    "observable": ("green", "#7fc97f"),
    "unobservable": ("magenta", "#e7298a"),
    "infeasible": ("white", "#ffffff"),
}


def plot_region_cut(cut, path: str | Path, title: str = "", units: Mapping[str, str] | None = None) -> Path:
    """Save a PNG of a cut of the observability regions, both axes unscaled with their units.

    The grid points are drawn observable (:data:`CUT_COLOURS`: green), unobservable ``B_T``
    (magenta) and outside ``X*_T`` (white), with a legend; the fixed states go in the title.

    Parameters
    ----------
    cut : Cut
        From :func:`hybobs_opt.regions.compute_cut`.
    path : path-like
        Output file (PNG).
    title : str
        Figure title; default: the fixed states.
    units : mapping of str, optional
        ``{state name: unit}``; a free axis without one is labelled with its name only.

    Returns
    -------
    Path
        The file written.

    See Also
    --------
    hybobs_opt.regions.compute_cut : the cut.
    hybobs_opt.regions.plot_cut : the same drawing without units.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import analyse_observability, get_example
    >>> from hybobs_opt.regions import compute_cut
    >>> from hybobs_opt.report import plot_region_cut
    >>> cut = compute_cut(analyse_observability(get_example("powertrain3").build(), 3), {"omega_l": 25.0},
    ...                   resolution=(11, 9))
    >>> path = plot_region_cut(cut, Path(tempfile.mkdtemp()) / "cut.png", units={"theta": "rad", "omega_m": "rad/s"})
    >>> path.read_bytes()[1:4]
    b'PNG'
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from ..regions import PointClass
    from ..regions.cuts import LABELS as order

    path = Path(path)
    units = units or {}
    code = np.vectorize({k: i for i, k in enumerate(order)}.get)(cut.labels)
    fig, ax = plt.subplots(figsize=(7.6, 4.6))
    dx = (cut.x_values[1] - cut.x_values[0]) / 2
    dy = (cut.y_values[1] - cut.y_values[0]) / 2
    ax.imshow(code, origin="lower", aspect="auto", interpolation="nearest",
              extent=(cut.x_values[0] - dx, cut.x_values[-1] + dx, cut.y_values[0] - dy, cut.y_values[-1] + dy),
              cmap=ListedColormap([CUT_COLOURS[k][1] for k in order]), vmin=0, vmax=len(order) - 1)
    ax.set_xlabel(quantity_label(cut.axes[0], units.get(cut.axes[0])))
    ax.set_ylabel(quantity_label(cut.axes[1], units.get(cut.axes[1])))
    fixed = ", ".join(f"{k} = {v:g}" + (f" {units[k]}" if units.get(k) else "") for k, v in cut.fixed.items())
    ax.set_title(title or f"cut at {fixed}", fontsize=9)
    ax.legend(handles=[Patch(color=CUT_COLOURS[PointClass.OBSERVABLE][1], label="observable (O_T)"),
                       Patch(color=CUT_COLOURS[PointClass.UNOBSERVABLE][1], label="unobservable (B_T)"),
                       Patch(facecolor=CUT_COLOURS[PointClass.INFEASIBLE][1], edgecolor="k", label="outside X*_T")],
              fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)  # beside, hiding no cell
    return save_figure(fig, path)
