"""Switched-gain design settings read from the model, for any scalar-nonlinear system (paper 004).

The paper's two examples come with hand-picked settings (the study
:mod:`hybobs_opt.studies.paper004_nonmonotonic.presets`); a user's system gets its settings here,
each from a rule on the model that is written down and reported with the value (``sources``):

* **scheduling coordinate**: the state on which the non-monotonic functions act (the argument
  ``E_i x`` of an ``f_i`` or ``C_j x`` of an ``h_j`` whose derivative changes sign on the box,
  eqs. 4-5); several candidates, or a non-monotonic function of a combination of states, need an
  explicit ``coordinate``;
* **range**: the coordinate's interval on the operating box;
* **state scaling** of the LMIs: per state, the distance it can move in one time unit (its largest
  rate over the box with zero input, :func:`max_rate`), capped by the half-width of its box
  interval (the half-width alone when the rate is 0).  A box that is much larger than the motion
  (positions bounded only for modelling) then does not make the LMI badly conditioned;
* **natural rate** ``rho``: the largest ``||S^-1 J(x) S||_2`` of the scaled Jacobian
  ``J = A + F diag(f'(E x)) E`` on :data:`~hybobs_opt.defaults.AUTO_DESIGN_RATE_SAMPLES` points of
  the box -- how fast the plant itself moves, in 1/time unit;
* **gain bound**: ``||L||_2 <= AUTO_DESIGN_GAIN_FACTOR * rho * max(S) / min(W)`` with
  ``W_j = ||C_j S||`` the output scales: the scaled gain at most
  :data:`~hybobs_opt.defaults.AUTO_DESIGN_GAIN_FACTOR` times the plant's rate (the rule of
  thumb "observer up to ten times faster than the plant"), so the gains stay of the size of the
  model's own numbers instead of growing until the decay-rate cap;
* **minimum decay** of each grown region: ``AUTO_DESIGN_DECAY_FACTOR * rho``;
* **hysteresis** ``epsilon``: :data:`~hybobs_opt.defaults.AUTO_DESIGN_OVERLAP_FRACTION` of the range;
* **maximum rate** of the coordinate (for the dwell-time guarantee): :func:`max_rate`;
* **region condition**: the least conservative condition of :mod:`.hierarchy` that can be built
  (``"polytopic"``, the vertex LMIs of the Jacobian box; ``"per_function"`` beyond
  :data:`~hybobs_opt.defaults.POLYTOPIC_MAX_VERTICES` vertices): every gain of the paper's LMI satisfies it, so the
  regions are at least as wide.

Every value can be given instead (``given`` in ``sources``).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._logging import with_verbose
from ..defaults import (AUTO_DESIGN_DECAY_FACTOR, AUTO_DESIGN_DECAY_FRACTION, AUTO_DESIGN_GAIN_FACTOR,
                        AUTO_DESIGN_OVERLAP_FRACTION, AUTO_DESIGN_RATE_FUNCTION_SAMPLES, AUTO_DESIGN_RATE_SAMPLES,
                        DWELL_RETRY_FRACTIONS, DWELL_RETRY_WIDEN, POLYTOPIC_MAX_VERTICES, SIGMA_CAP)
from ..errors import HybobsError, ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import AUTO_DESIGN_RATE_FLOOR
from .bounds import jacobian_bounds
from .schedule import coordinate_index


@dataclass(frozen=True)
class DesignSettings:
    """The settings of one switched-gain design, each with where it came from.

    Parameters
    ----------
    coordinate : str
        Scheduling state.
    lo, hi : float
        Scheduling range (model units).
    scaling : (n,) array
        State scaling of the LMIs.
    natural_rate : float
        ``rho`` (1/time unit), see the module docstring.
    gain_bound : float
        ``||L||_2`` bound (model units).
    min_decay : float
        Decay rate each grown region must admit (1/time unit).
    overlap : float
        Hysteresis ``epsilon`` (model units of the coordinate).
    max_rate : float
        Largest rate of the coordinate (model units per time unit).
    decay_fraction, sigma_cap : float
        Design rate as a fraction of the largest; upper end of the decay search.
    sources : dict
        Per setting, ``"given"`` or the rule that produced it.
    condition : {"paper", "per_function", "polytopic"}
        The region condition of :mod:`.hierarchy` the regions are grown with.

    See Also
    --------
    design_settings : Derives them from a model.
    design_switched : Designs the switched observer with them.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import design_settings
    >>> settings = design_settings(vehicle)
    >>> settings.coordinate, settings.condition
    ('psi', 'polytopic')
    >>> round(settings.gain_bound, 3), round(settings.min_decay, 4), round(settings.overlap, 4)
    (10.206, 0.1021, 0.0314)
    >>> settings.sources["overlap"]
    '0.005 x range'
    """

    coordinate: str
    lo: float
    hi: float
    scaling: np.ndarray
    natural_rate: float
    gain_bound: float
    min_decay: float
    overlap: float
    max_rate: float
    decay_fraction: float = AUTO_DESIGN_DECAY_FRACTION
    sigma_cap: float = SIGMA_CAP
    sources: dict[str, str] = field(default_factory=dict)
    condition: str = "polytopic"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``settings`` of ``hybobs synth/diagnose --json``).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"coordinate": self.coordinate, "range": [self.lo, self.hi], "scaling": self.scaling.tolist(),
                "natural_rate": self.natural_rate, "gain_bound": self.gain_bound, "min_decay": self.min_decay,
                "overlap": self.overlap, "max_rate": self.max_rate, "decay_fraction": self.decay_fraction,
                "sigma_cap": self.sigma_cap, "condition": self.condition, "sources": dict(self.sources)}


def max_rate(system: ScalarNonlinearSystem, coordinate: int, samples: int = AUTO_DESIGN_RATE_FUNCTION_SAMPLES) -> float:
    """Largest ``|x_k'|`` over the operating box with zero input (model units per time unit).

    Each state derivative of the class is a sum of terms in single box coordinates or single
    ``E_i x``, so it is bounded over samples of each coordinate's range separately (the bound is
    attained when the terms peak together, as for the paper's vehicle and piston).
    """
    lo, hi = system.box_lower, system.box_upper
    rate = float(np.sum(np.abs(system.A[coordinate]) * np.maximum(np.abs(lo), np.abs(hi))))
    for i, fn in enumerate(system.f):
        w = abs(system.F[coordinate, i])
        if w == 0:
            continue
        a, b = system.f_ranges[i]
        rate += w * float(np.max(np.abs(fn.value(np.linspace(a, b, samples)))))
    return rate


def model_scaling(system: ScalarNonlinearSystem) -> np.ndarray:
    """Per state ``min(half-width, max_rate * 1 time unit)`` (the half-width when the rate is 0)."""
    half = 0.5 * (system.box_upper - system.box_lower)
    half = np.where(half > 0, half, 1.0)
    rates = np.array([max_rate(system, k) for k in range(system.n)])
    return np.where(rates > 0, np.minimum(half, rates), half).astype(float)


def natural_rate(system: ScalarNonlinearSystem, scaling: np.ndarray, samples: int = AUTO_DESIGN_RATE_SAMPLES) -> float:
    """``max ||S^-1 J(x) S||_2`` over ``samples`` seeded random points of the box (and its corners' centre)."""
    rng = np.random.default_rng(0)
    lo, hi = system.box_lower, system.box_upper
    X = np.vstack([(lo + hi) / 2.0, lo + (hi - lo) * rng.random((samples, system.n))])
    J = system.dynamics_jacobian(X)
    Js = J / scaling[None, :, None] * scaling[None, None, :]
    return float(np.linalg.norm(Js, 2, axis=(1, 2)).max())


def scheduling_candidates(system: ScalarNonlinearSystem) -> dict[str, list[str]]:
    """States on which a non-monotonic function acts: ``{state: [function names]}``.

    A function of a combination of several states is listed under ``"<combination>"``.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system; monotonicity is judged from its Jacobian bounds on the whole box.

    Returns
    -------
    dict of str to list of str
        ``{state name: [names of the non-monotonic functions acting on it]}``; empty when every
        function is monotonic on the box.

    See Also
    --------
    design_settings : Picks the scheduling state from these candidates.
    monotonic_pieces : Where the functions change direction along a state.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import scheduling_candidates
    >>> scheduling_candidates(vehicle)
    {'psi': ['f[0] (V cos(psi))', 'f[1] (V sin(psi))']}
    """
    bounds = jacobian_bounds(system, None)
    out: dict[str, list[str]] = {}
    for label, rows, fns, bds in (("f", system.E, system.f, bounds.f), ("h", system.C, system.h, bounds.h)):
        for i, (fn, b) in enumerate(zip(fns, bds)):
            if b.monotonic:
                continue
            nz = np.flatnonzero(rows[i])
            key = system.state_names[int(nz[0])] if nz.size == 1 else "<combination>"
            out.setdefault(key, []).append(f"{label}[{i}] ({fn.name})")
    return out


def design_settings(system: ScalarNonlinearSystem, coordinate: int | str | None = None, lo: float | None = None,
                    hi: float | None = None, *, gain_bound: float | None = None, min_decay: float | None = None,
                    overlap: float | None = None, rate: float | None = None, scaling=None,
                    condition: str | None = None) -> DesignSettings:
    """Settings for :func:`design_switched` / :func:`~hybobs_opt.lmi.diagnose.diagnose` from the model (module docstring).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    coordinate : int or str, optional
        The scheduling state; ``None`` picks the state the non-monotonic functions act on.
    lo, hi : float, optional
        The scheduling range in model units (default: the coordinate's interval on the box).
    gain_bound : float, optional
        Bound on ``||L||_2`` (default: the gain rule above).
    min_decay : float, optional
        Minimum decay rate of each grown region (default ``AUTO_DESIGN_DECAY_FACTOR * rho``).
    overlap : float, optional
        Hysteresis ``epsilon``, ``>= 0`` (default ``AUTO_DESIGN_OVERLAP_FRACTION`` of the range).
    rate : float, optional
        Largest rate of the coordinate, for the dwell time (default :func:`max_rate`).
    scaling : (n,) array_like, optional
        State scaling of the LMIs (default: the rule above).
    condition : {"paper", "per_function", "polytopic"}, optional
        The region condition (default: the least conservative one that can be built).

    Returns
    -------
    DesignSettings
        The coordinate, range, scaling, gain bound, decay rate, overlap and rate bound, with
        ``sources`` saying where each value came from (given, or which rule).

    Raises
    ------
    ModelError
        Not a scalar-nonlinear system; the coordinate cannot be chosen (several candidates, a
        combination of states) and was not given; a given value out of range.

    See Also
    --------
    DesignSettings : What it returns.
    design_switched : Uses the settings.
    scheduling_candidates : The states a design can be scheduled on.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import design_settings
    >>> settings = design_settings(vehicle, lo=0.0, hi=math.radians(140), overlap=math.radians(10))
    >>> settings.coordinate, round(math.degrees(settings.hi))
    ('psi', 140)
    >>> settings.sources["coordinate"]
    'the state the non-monotonic f[0] (V cos(psi)), f[1] (V sin(psi)) act on'
    """
    if not isinstance(system, ScalarNonlinearSystem):
        raise ModelError("system", "a ScalarNonlinearSystem (the observer LMIs of paper 004)", type(system).__name__)
    sources: dict[str, str] = {}
    if coordinate is None:
        cands = scheduling_candidates(system)
        single = [k for k in cands if k != "<combination>"]
        if len(cands) == 1 and single:
            coordinate = single[0]
            sources["coordinate"] = f"the state the non-monotonic {', '.join(cands[single[0]])} act on"
        elif not cands:
            coordinate = system.state_names[int(np.flatnonzero(system.E[0])[0])] if system.r and np.any(system.E[0]) else system.state_names[0]
            sources["coordinate"] = "every function is monotonic on the box (one region suffices); the first argument"
        else:
            raise ModelError("coordinate", "a scheduling state (several non-monotonic functions act on "
                             f"{', '.join(f'{k}: {v}' for k, v in cands.items())})", "none given")
    else:
        sources["coordinate"] = "given"
    k = coordinate_index(system, coordinate)
    name = system.state_names[k]
    sources["range"] = "the operating box" if lo is None and hi is None else "given"
    lo = float(system.box_lower[k]) if lo is None else float(lo)
    hi = float(system.box_upper[k]) if hi is None else float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ModelError("range", f"finite lo < hi for {name}", f"[{lo}, {hi}]")
    if scaling is None:
        S = model_scaling(system)
        sources["scaling"] = "per state min(box half-width, largest rate x 1 time unit)"
    else:
        S = np.asarray(scaling, dtype=float).reshape(-1)
        if S.shape != (system.n,) or not np.all(np.isfinite(S) & (S > 0)):
            raise ModelError("scaling", f"{system.n} positive numbers", repr(scaling))
        sources["scaling"] = "given"
    rho = max(natural_rate(system, S), AUTO_DESIGN_RATE_FLOOR)
    W = np.linalg.norm(system.C * S[None, :], axis=1)
    W = np.where(W > 0, W, 1.0)

    def pick(value, label, default, rule):
        if value is None:
            sources[label] = rule
            return float(default)
        if not (np.isfinite(value) and value > 0) and not (label == "overlap" and value == 0):
            raise ModelError(label, "a positive finite number", repr(value))
        sources[label] = "given"
        return float(value)

    gb = pick(gain_bound, "gain_bound", AUTO_DESIGN_GAIN_FACTOR * rho * S.max() / W.min(),
              f"{AUTO_DESIGN_GAIN_FACTOR:g} x natural rate x max(scaling) / min(output scale)")
    md = pick(min_decay, "min_decay", AUTO_DESIGN_DECAY_FACTOR * rho, f"{AUTO_DESIGN_DECAY_FACTOR:g} x natural rate")
    ov = pick(overlap, "overlap", AUTO_DESIGN_OVERLAP_FRACTION * (hi - lo), f"{AUTO_DESIGN_OVERLAP_FRACTION:g} x range")
    mr = pick(rate, "max_rate", max(max_rate(system, k), AUTO_DESIGN_RATE_FLOOR),
              "largest rate of the coordinate on the box (zero input)")
    cap = max(SIGMA_CAP, 10.0 * rho)
    from .hierarchy import CONDITIONS

    if condition is None:
        k_fn = system.r + sum(not lin for lin in system.linear_outputs)
        condition = "polytopic" if 2 ** k_fn <= POLYTOPIC_MAX_VERTICES else "per_function"
        sources["condition"] = "the least conservative condition that can be built (vertices of the Jacobian box)"
    elif condition not in CONDITIONS:
        raise ModelError("condition", f"one of {CONDITIONS}", repr(condition))
    else:
        sources["condition"] = "given"
    return DesignSettings(name, lo, hi, S, rho, gb, md, ov, mr, AUTO_DESIGN_DECAY_FRACTION, cap, sources, condition)


_log = logging.getLogger(__name__)


@with_verbose
def design_switched(system: ScalarNonlinearSystem, settings: DesignSettings, *, accept_unenforced_dwell: bool = False,
                    verbose: bool | int = False):
    """Regions grown on the settings' range and the switched gains with the dwell time (paper 004, Section 5).

    When the hysteresis does not enforce the dwell time (Theorem 6 needs it), the design is redone
    with a smaller design-rate fraction (:data:`~hybobs_opt.defaults.DWELL_RETRY_FRACTIONS`) and
    then, unless the overlap was given, with the overlap widened to the required hysteresis
    (times :data:`~hybobs_opt.defaults.DWELL_RETRY_WIDEN`); the attempts are recorded on
    the design (``design.dwell_attempts``).  If none enforces it, :class:`~hybobs_opt.lmi.switched.DwellTimeError`
    is raised unless ``accept_unenforced_dwell`` (then the last design comes with a
    :class:`~hybobs_opt.lmi.switched.DwellTimeWarning` and the text in ``design.warnings``).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    settings : DesignSettings
        The settings (:func:`design_settings`).
    accept_unenforced_dwell : bool, default False
        Return the last design with a warning instead of raising when no attempt enforces the dwell
        time.
    verbose : bool or int, default False
        Log the progress (and every LMI solve at DEBUG) to standard error: ``True`` at INFO, or a
        logging level (:func:`hybobs_opt._logging.verbose_logging`).

    Returns
    -------
    SwitchedDesign
        The regions, gains, dwell time and the attempts made.

    See Also
    --------
    design_settings : The settings it takes.
    grow_regions : The regions it grows.
    synthesize_switched : The gains it computes on them.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import design_settings, design_switched

    With the yaw rate bounded by 0.02 rad/s a 5 deg hysteresis enforces the dwell time:

    >>> settings = design_settings(vehicle, lo=0.0, hi=math.radians(140), rate=0.02,
    ...                            overlap=math.radians(5))
    >>> design = design_switched(vehicle, settings)
    >>> len(design.regions), design.dwell_enforced, bool(design.dwell_guaranteed >= design.tau)
    (2, True, True)
    """
    import warnings

    from .switched import DwellTimeError, DwellTimeWarning, grow_regions, synthesize_switched

    plans = [(settings.overlap, settings.decay_fraction)]
    plans += [(settings.overlap, f) for f in DWELL_RETRY_FRACTIONS if f < settings.decay_fraction]
    attempts: list[dict] = []
    design = None
    overlap_given = settings.sources.get("overlap") == "given"
    i = 0
    while i < len(plans):
        overlap, fraction = plans[i]
        try:
            regions = grow_regions(system, settings.coordinate, settings.lo, settings.hi, overlap=overlap,
                                   min_decay=settings.min_decay, gain_bound=settings.gain_bound,
                                   scaling=settings.scaling, condition=settings.condition)
        except HybobsError as exc:
            if design is None:
                raise
            # a retry with a wider overlap found no regions: keep the last design
            attempts.append({"overlap": overlap, "decay_fraction": fraction, "error": str(exc)})
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DwellTimeWarning)
            design = synthesize_switched(system, regions, gain_bound=settings.gain_bound, decay_fraction=fraction,
                                         sigma_cap=settings.sigma_cap, scaling=settings.scaling,
                                         max_rate=settings.max_rate, overlap=overlap, accept_unenforced_dwell=True,
                                         condition=settings.condition, min_decay=settings.min_decay)
        _log.info("design attempt %d: overlap %.4g, decay fraction %.3g: %d regions, dwell time %.4g s, enforced: %s",
                  len(attempts) + 1, overlap, fraction, len(design.regions), design.tau, design.dwell_enforced)
        attempts.append({"overlap": overlap, "decay_fraction": fraction, "regions": len(design.regions),
                         "tau": design.tau, "epsilon_required": design.epsilon_required,
                         "dwell_enforced": design.dwell_enforced})
        if design.dwell_enforced is not False:
            break
        if i == len(plans) - 1 and not overlap_given and len(plans) < len(DWELL_RETRY_FRACTIONS) + 3:
            plans.append((DWELL_RETRY_WIDEN * float(design.epsilon_required), settings.decay_fraction))
        i += 1
    design = dataclasses.replace(design, dwell_attempts=attempts, accepted_unenforced_dwell=bool(accept_unenforced_dwell))
    if design.dwell_enforced is False:
        if not accept_unenforced_dwell:
            raise DwellTimeError(design)
        for text in design.warnings:
            # 3: the caller of the verbose wrapper (hybobs_opt._logging.with_verbose)
            warnings.warn(text, DwellTimeWarning, stacklevel=3)
    return design
