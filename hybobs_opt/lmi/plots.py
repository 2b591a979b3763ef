"""Figures of the LMI results: a :class:`~hybobs_opt.lmi.diagnose.Diagnosis`'s Jacobian bounds, the noise-bound trade-off."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..plotting import pyplot, quantity_label

plt = pyplot()
import numpy as np  # noqa: E402


def plot_jacobian_bounds(diag, path: str | Path, samples: int = 721,
                         units: Mapping[str, tuple[str, str]] | None = None) -> Path:
    """Each nonlinear function's derivative over the range with its bounds (eqs. 4-5) and pieces.

    Functions of the scheduling coordinate are drawn against it (display units), with the
    slope-change points and the suggested switching regions; the others against their own argument.

    Parameters
    ----------
    diag : Diagnosis
        From :func:`hybobs_opt.lmi.diagnose.diagnose`.
    path : path-like
        Output file (PNG).
    samples : int
        Points per curve.
    units : mapping, optional
        ``{function name: (unit of its value, unit of its argument in model units)}``: the slope
        axis is then labelled ``"slope of f[i] [VALUE per ARGUMENT]"`` (the panel's title names the
        function); without an entry it carries no unit (a user system declares none).

    Returns
    -------
    Path
        The file written.

    See Also
    --------
    diagnose : The diagnosis it draws.
    jacobian_bounds : The bounds drawn.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import diagnose, plot_jacobian_bounds
    >>> diag = diagnose(vehicle, "psi", 0.0, math.radians(140), unit="deg", factor=math.pi / 180,
    ...                 suggest=False)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = plot_jacobian_bounds(diag, Path(tmp) / "bounds.png", samples=91)
    ...     print(path.name, path.stat().st_size > 0)
    ...
    bounds.png True
    """
    path = Path(path)
    system = diag.system
    k = diag.region.coordinate
    nl = [(b, system.E[b.index] if b.kind == "f" else system.C[b.index],
           system.f[b.index] if b.kind == "f" else system.h[b.index])
          for b in (*diag.bounds.f, *diag.bounds.h) if b.method != "linear"]
    fig, axes = plt.subplots(len(nl), 1, figsize=(7.5, 1.9 * len(nl) + 0.8), squeeze=False)
    centre = 0.5 * (system.box_lower + system.box_upper)
    for ax, (b, row, fn) in zip(axes[:, 0], nl):
        if row[k] != 0:
            s = np.linspace(diag.region.lo, diag.region.hi, samples)
            z = row @ centre - row[k] * centre[k] + row[k] * s
            xs, xlabel = s / diag.factor, f"{diag.region.name} [{diag.unit}]" if diag.unit else diag.region.name
            for bp in diag.breakpoints:
                ax.axvline(bp / diag.factor, color="0.6", lw=0.8, ls=":")
            for i, r in enumerate(diag.suggested or []):
                ax.axvspan(r.lo / diag.factor, r.hi / diag.factor, color=f"C{i % 10}", alpha=0.08)
        else:
            z = np.linspace(*b.interval, samples)
            xs, xlabel = z, quantity_label(f"argument of {b.name}", (units or {}).get(b.name, ("", ""))[1])
        value_unit, arg_unit = (units or {}).get(b.name, ("", ""))
        ax.plot(xs, fn.deriv(z), lw=1.2, color="k")
        # the title names the function; the short name keeps a long expression inside the figure
        ax.set_ylabel(quantity_label(f"slope of {b.kind}[{b.index}]", f"{value_unit} per {arg_unit}" if value_unit and arg_unit
                                     else ""), fontsize=8)
        ax.axhline(b.lower, color="tab:blue", lw=1, ls="--", label=f"lower {b.lower:.3g}")
        ax.axhline(b.upper, color="tab:red", lw=1, ls="--", label=f"upper {b.upper:.3g}")
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.set_title(f"{b.kind}[{b.index}] = {b.name}: {b.monotonicity}", fontsize=9)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{system.name}: Jacobian bounds (eqs. 4-5), {diag.region.name} in "
                 f"[{diag.region.lo / diag.factor:.4g}, {diag.region.hi / diag.factor:.4g}] {diag.unit}", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_noise_tradeoff(curve, path: str | Path, design=None, state_names=None) -> Path:
    """The smallest certified error bound against the decay rate of ``V`` (:func:`.noise_gain.noise_tradeoff`).

    Top: the worst per-state bound relative to the reference sizes; bottom: each state's bound in
    model units.  Rates with no certified design are left out.

    Parameters
    ----------
    curve : NoiseTradeoff
        From :func:`hybobs_opt.lmi.noise_gain.noise_tradeoff`.
    path : path-like
        Output file (PNG).
    design : NoiseBoundDesign, optional
        A design to mark (e.g. the one of :func:`~hybobs_opt.lmi.noise_gain.noise_optimal_design`).
    state_names : sequence of str, optional
        Labels of the states (default ``x1, x2, ...``).

    Returns
    -------
    Path
        The file written.

    See Also
    --------
    noise_tradeoff : The curve it draws.
    noise_optimal_design : One point of the curve.

    Examples
    --------
    >>> import numpy as np
    >>> import tempfile
    >>> from pathlib import Path
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import noise_tradeoff, plot_noise_tradeoff
    >>> curve = noise_tradeoff(pendulum, bounds, [0.01], [0.1, 0.5, 1.0], gain_bound=10.0)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = plot_noise_tradeoff(curve, Path(tmp) / "tradeoff.png", state_names=("theta", "omega"))
    ...     print(path.suffix, path.stat().st_size > 0)
    ...
    .png True
    """
    path = Path(path)
    ok = np.asarray(curve.feasible, dtype=bool)
    a = np.asarray(curve.alpha_certified, dtype=float)[ok]
    n = curve.bound.shape[1]
    names = list(state_names) if state_names is not None else [f"x{k + 1}" for k in range(n)]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 6.0), sharex=True)
    top.loglog(a, np.asarray(curve.worst_relative)[ok], "o-", color="k", lw=1.2, ms=3)
    top.set_ylabel("worst bound / reference size", fontsize=8)
    for k in range(n):
        bottom.loglog(a, curve.bound[ok, k], "o-", lw=1.0, ms=3, label=names[k])
    bottom.set_ylabel("ultimate bound on |e_k| (model units)", fontsize=8)
    bottom.set_xlabel("decay rate alpha of V = e'Pe (1/s)", fontsize=8)
    if design is not None and getattr(design, "feasible", False):
        top.axvline(design.alpha, color="tab:red", lw=0.8, ls="--", label=f"design alpha = {design.alpha:.3g}")
        top.legend(fontsize=7, loc="best")
    bottom.legend(fontsize=7, loc="best")
    for ax in (top, bottom):
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("certified error bound under bounded noise against the decay rate", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


__all__ = ["plot_jacobian_bounds", "plot_noise_tradeoff"]
