"""2-D cuts of the observability regions (paper 002, Figs. 3-6), from exact point queries.

A cut fixes all states but two; every grid point of the remaining plane is classified exactly
by :meth:`ObservabilityAnalysis.classify` (a :class:`~hybobs_opt.regions.PointClass`:
``observable`` / ``unobservable`` / ``infeasible``, i.e. outside ``X*_T``), so the picture and the numbers asserted by the tests are the same data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .verdicts import PointClass

#: The labels of a cut, in the order of the colours of :func:`plot_cut`.
LABELS = (PointClass.OBSERVABLE, PointClass.UNOBSERVABLE, PointClass.INFEASIBLE)


@dataclass(frozen=True, eq=False)
class Cut:
    """Classification of a grid in the plane of two states, the others fixed.

    Parameters
    ----------
    axes : (str, str)
        Names of the free states (horizontal, vertical).
    fixed : dict
        The fixed states and their values.
    x_values, y_values : arrays
        Grid coordinates.
    labels : (len(y), len(x)) object array
        One of :data:`LABELS` (a :class:`~hybobs_opt.regions.PointClass`, equal to its string) per grid point.

    See Also
    --------
    compute_cut : computes it.
    plot_cut : draws it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> from hybobs_opt.regions import compute_cut
    >>> cut = compute_cut(analysis, {"omega_l": 25.0}, resolution=(11, 9))
    >>> cut.fixed, cut.x_values.shape, cut.y_values.shape
    ({'omega_l': 25.0}, (11,), (9,))
    >>> sorted({label.value for label in cut.labels.ravel()})
    ['infeasible', 'observable', 'unobservable']
    """

    axes: tuple[str, str]
    fixed: dict
    x_values: np.ndarray
    y_values: np.ndarray
    labels: np.ndarray

    def fraction(self, label: str, mask: np.ndarray | None = None) -> float:
        """Share of grid points (optionally within ``mask``) carrying ``label``.

        Parameters
        ----------
        label : str
            One of :data:`LABELS`.
        mask : boolean ndarray, optional
            Grid points to count (shape of :attr:`labels`); ``None`` counts all.

        Returns
        -------
        float
            The share, ``nan`` when no point is selected.
        """
        sel = self.labels if mask is None else self.labels[mask]
        return float(np.mean(sel == label)) if sel.size else float("nan")

    def fraction_of_feasible(self, label: str, mask: np.ndarray | None = None) -> float:
        """Share of the points of ``X*_T`` (optionally within ``mask``) carrying ``label``.

        Parameters
        ----------
        label : str
            One of :data:`LABELS`.
        mask : boolean ndarray, optional
            Grid points to count (shape of :attr:`labels`); ``None`` counts all feasible ones.

        Returns
        -------
        float
            The share, ``nan`` when no feasible point is selected.
        """
        m = self.labels != PointClass.INFEASIBLE
        if mask is not None:
            m &= mask
        return float(np.mean(self.labels[m] == label)) if m.any() else float("nan")

    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The grid coordinates of the cut.

        Returns
        -------
        X, Y : (ny, nx) ndarray
            ``numpy.meshgrid`` of ``x_values`` and ``y_values``, shaped like ``labels``.
        """
        return np.meshgrid(self.x_values, self.y_values)

    def to_dict(self) -> dict:
        """JSON-ready record of the cut.

        Returns
        -------
        dict
            ``axes``, ``fixed``, ``x_values``, ``y_values``, ``labels`` (nested lists) and
            ``fraction_observable_of_feasible``.
        """
        return {
            "axes": list(self.axes),
            "fixed": dict(self.fixed),
            "x_values": self.x_values.tolist(),
            "y_values": self.y_values.tolist(),
            "labels": self.labels.tolist(),
            "fraction_observable_of_feasible": self.fraction_of_feasible(PointClass.OBSERVABLE),
        }


def parse_assignments(items: list[str] | None, state_names: tuple[str, ...], option: str = "fixed") -> dict[str, float]:
    """Parse ``["omega_l=25", ...]`` into ``{name: value}`` with the names checked (errors name ``option``).

    Parameters
    ----------
    items : list of str, optional
        ``NAME=VALUE`` strings; ``None`` gives ``{}``.
    state_names : tuple of str
        The allowed names.
    option : str, default "fixed"
        Name of the option in error messages (e.g. the command-line flag).

    Returns
    -------
    dict of str to float
        The values by state name, in the order given.

    Raises
    ------
    ModelError
        On an item without ``=``, an unknown name, or a value that is not a number.

    See Also
    --------
    compute_cut : takes the result as ``fixed``.

    Examples
    --------
    >>> from hybobs_opt.regions import parse_assignments
    >>> parse_assignments(["omega_l=25", "theta=0.01"], ("theta", "omega_m", "omega_l"))
    {'omega_l': 25.0, 'theta': 0.01}
    >>> parse_assignments(["speed=3"], ("theta", "omega_m", "omega_l"), option="--cut")
    Traceback (most recent call last):
    ...
    hybobs_opt.errors.ModelError: --cut: expected ...
    """
    out: dict[str, float] = {}
    for item in items or []:
        if "=" not in item:
            raise ModelError(option, "NAME=VALUE with NAME a state name", repr(item))
        name, value = (s.strip() for s in item.split("=", 1))
        if name not in state_names:
            raise ModelError(option, f"a state name among {state_names}", repr(name))
        try:
            out[name] = float(value)
        except ValueError:
            raise ModelError(f"{option} {name}", "a number", repr(value)) from None
    return out


def compute_cut(
    analysis,
    fixed: dict[str, float],
    resolution: tuple[int, int] = (41, 31),
    limits: dict[str, tuple[float, float]] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Cut:
    """Classify a grid of the plane left free by ``fixed`` (which must fix all states but two).

    Parameters
    ----------
    analysis : ObservabilityAnalysis
    fixed : dict
        ``{state name: value}`` for ``n - 2`` states.
    resolution : (int, int)
        Grid points along the horizontal and vertical axes.
    limits : dict, optional
        ``{state name: (lo, hi)}`` for the free axes; default: the state bounds.
    progress : callable, optional
        ``progress(done, total)`` after each grid point is classified.

    Returns
    -------
    Cut
        The grid and its labels (observable, unobservable, outside ``X*_T``).

    See Also
    --------
    Cut : what it returns.
    plot_cut : draws it.
    parse_assignments : the ``fixed`` states from ``NAME=VALUE`` strings.

    Examples
    --------
    The plane ``(theta, omega_m)`` at ``omega_l = 25`` rad/s, like Fig. 3 of paper 002, on a coarse
    grid:

    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> from hybobs_opt.regions import compute_cut
    >>> cut = compute_cut(analysis, {"omega_l": 25.0}, resolution=(21, 15))
    >>> cut.axes, cut.labels.shape
    (('theta', 'omega_m'), (15, 21))
    >>> round(cut.fraction("observable"), 3), round(cut.fraction_of_feasible("observable"), 3)
    (0.638, 0.703)
    """
    system = analysis.system
    names = system.state_names
    free = [k for k, nm in enumerate(names) if nm not in fixed]
    if len(free) != 2:
        raise ModelError("fixed", f"values for exactly {system.n - 2} of the states {names} (two stay free)",
                         f"{sorted(fixed)}")
    nx, ny = resolution
    if nx < 2 or ny < 2:
        raise ModelError("resolution", "at least 2 points per axis", repr(resolution))
    lo, hi = system.state_bounds.bounding_box()
    limits = limits or {}
    axes = []
    for k in free:
        a, b = limits.get(names[k], (lo[k], hi[k]))
        axes.append(np.linspace(a, b, nx if len(axes) == 0 else ny))
    X = np.zeros((ny, nx, system.n))
    for nm, v in fixed.items():
        X[:, :, names.index(nm)] = v
    gx, gy = np.meshgrid(axes[0], axes[1])
    X[:, :, free[0]] = gx
    X[:, :, free[1]] = gy
    labels = analysis.classify_many(X.reshape(-1, system.n), progress=progress).reshape(ny, nx)
    return Cut((names[free[0]], names[free[1]]), dict(fixed), axes[0], axes[1], labels)


def plot_cut(cut: Cut, path, title: str = "", stretch: dict[str, float] | None = None,
             units: dict[str, str] | None = None):
    """Save a PNG of the cut: observable (green), unobservable (magenta), outside ``X*_T`` (white).

    ``stretch`` multiplies an axis for display (the paper multiplies the theta axis by 10).

    Parameters
    ----------
    cut : Cut
        The classified grid (:func:`compute_cut`).
    path : str or Path
        Output PNG file.
    title : str, optional
        Figure title; empty gives ``"cut at NAME = VALUE, ..."``.
    stretch : dict of str to float, optional
        Display factor per axis name.
    units : dict of str to str, optional
        ``{state name: unit}``: an axis with a unit is labelled ``"name [unit]"``.

    Returns
    -------
    str or Path
        ``path``.

    See Also
    --------
    compute_cut : the cut.
    hybobs_opt.report.plot_region_cut : the report's version, with units.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.regions import compute_cut, plot_cut
    >>> cut = compute_cut(analysis, {"omega_l": 25.0}, resolution=(11, 9))
    >>> path = plot_cut(cut, Path(tempfile.mkdtemp()) / "cut.png", title="T = 3, omega_l = 25")
    >>> Path(path).read_bytes()[:4]
    b'...PNG'
    """
    from ..plotting import pyplot

    plt = pyplot()
    from matplotlib.colors import ListedColormap

    code = np.vectorize({label: k for k, label in enumerate(LABELS)}.get)(cut.labels)
    sx = (stretch or {}).get(cut.axes[0], 1.0)
    sy = (stretch or {}).get(cut.axes[1], 1.0)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    dx = (cut.x_values[1] - cut.x_values[0]) * sx / 2
    dy = (cut.y_values[1] - cut.y_values[0]) * sy / 2
    ax.imshow(code, origin="lower", aspect="auto", interpolation="nearest",
              extent=(cut.x_values[0] * sx - dx, cut.x_values[-1] * sx + dx, cut.y_values[0] * sy - dy, cut.y_values[-1] * sy + dy),
              cmap=ListedColormap(["#7fc97f", "#e7298a", "#ffffff"]), vmin=0, vmax=2)
    units = units or {}

    def label(name: str, factor: float) -> str:
        unit = f" [{units[name]}]" if units.get(name) else ""
        return (f"{factor:g} {name}" if factor != 1 else name) + unit

    ax.set_xlabel(label(cut.axes[0], sx))
    ax.set_ylabel(label(cut.axes[1], sy))
    fixed = ", ".join(f"{k} = {v:g}" for k, v in cut.fixed.items())
    ax.set_title(title or f"cut at {fixed}", fontsize=10)
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(color="#7fc97f", label="observable (O_T)"), Patch(color="#e7298a", label="unobservable (B_T)"),
                       Patch(facecolor="white", edgecolor="k", label="outside X*_T")], fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
