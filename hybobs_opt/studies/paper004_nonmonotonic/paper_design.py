"""Paper 004's vehicle observer as published (Sec. 6, eqs. 61-62) against the toolbox's synthesis.

What was read from the paper (``/work/shared/seeds/004_*.txt``, Sec. 6.1-6.2):

* eq. (61), "Gain L_1 for the operating range 0 deg <= psi <= 80 deg, -10 deg <= delta_f <= 10 deg"::

      L_1 = [[  42.1703, -23.6081],
             [ -51.8942,  41.5463],
             [-121.0412,  86.8002],
             [  -1.7662,   1.2666]]

* eq. (62), "Gain L_2 for the operating range 60 deg <= psi <= 140 deg, -10 deg <= delta_f <= 10 deg"::

      L_2 = [[  46.4268,   3.2988],
             [   8.4042,   5.0011],
             [ -75.2145,  -6.8793],
             [  -1.1358,  -0.1039]]

  The extraction printed both as clean 4 x 2 bmatrices (four rows of two numbers with four decimals
  each); nothing had to be reconstructed.  Rows are the states of eq. (56), ``X, Y, psi, delta_f``,
  columns the radar outputs ``X, Y`` of eq. (58).  **Assumed** (the paper states no units): the
  gains act in the model's units, positions in m and angles in rad (``psi``-row entries in
  rad/(m s)); the paper's own yaw equation uses ``tan(delta_f)`` of an angle in rad.  With these units
  the frozen error dynamics ``A(x) - L C`` of this toolbox's vehicle model are Hurwitz for L_1 over
  its 0-80 deg and for L_2 over 60-140 deg (:func:`frozen_stability_limit`: L_1 in fact up to
  123.1 deg, the same for ``l_f + l_r`` from 1 to 20 m); their slowest eigenvalue (about -0.055 1/s with
  ``l_f + l_r`` = 2.68 m, the model's assumption) is the steering mode, and it scales with
  ``V/(l_f + l_r)``, which the paper does not give.
* The switching rule, Sec. 6.2: "The observer gain is switched at 60 degrees of the estimated yaw
  angle."  Sec. 6.1 adds "It can be seen that the two gains overlap over 20 degrees of yaw angle
  regime" (the 60-80 deg overlap).  The paper states no switching point for the way back and no
  hysteresis for the vehicle.

The regions handed to the observer are therefore ``[0, 60 + eps] deg`` (L_1) and
``[60 - eps, 140] deg`` (L_2) with ``eps`` = :data:`PAPER_HYSTERESIS_DEG` = 0 by default: the
toolbox's state machine leaves a region when the estimate leaves it, so with ``eps = 0`` the switch
up happens as soon as the estimated yaw exceeds 60 deg, which is the sentence above, and the switch
back below 60 deg.  Both gains are then used only inside their published ranges (L_1 on 0-60 deg
inside 0-80, L_2 on 60-140).  A positive ``eps`` adds hysteresis (the Fig. 1 machine), at the price
of using L_2 down to ``60 - eps`` deg, below its published range, and delaying the switch up to
``60 + eps``.  The preset of the toolbox's own synthesis instead splits the same 0-80 / 60-140 deg
ranges at a nominal 70 deg with ``epsilon`` = 10 deg (:mod:`.presets`), so its switch up is at 80 deg.

The paper gives no Lyapunov matrix or decay rate for its gains: the :class:`~hybobs_opt.lmi.RegionGain`
objects carry ``P = I`` and ``sigma = sigma_max = nan`` (only ``L`` and ``region`` are used by the
observer); ``bounds`` are the Jacobian bounds over the switching region.

:func:`run_paper_comparison` runs the paper's gains and the synthesised ones on the paper's
scenario (:func:`~.systems.vehicle_scenario`), all with the yaw wrapped modulo 2 pi.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.lmi import RegionGain, jacobian_bounds
from hybobs_opt.lmi.schedule import make_region
from hybobs_opt.observers.switched_gain import SwitchedGainObserver, convergence_time
from hybobs_opt.studies.registry import get_example
from hybobs_opt.systems.scalar_nonlinear import ScalarNonlinearSystem

from .presets import get_preset
from .scenarios import CONVERGENCE_TOL, PERIODIC, VEHICLE_X_HAT0, cached_design
from .systems import VEHICLE_TURN_RATE_DEG_S

#: Paper 004 eq. (61): observer gain for 0 <= psi <= 80 deg, |delta_f| <= 10 deg (rows X, Y, psi, delta_f).
PAPER_L1 = ((42.1703, -23.6081), (-51.8942, 41.5463), (-121.0412, 86.8002), (-1.7662, 1.2666))
#: Paper 004 eq. (62): observer gain for 60 <= psi <= 140 deg, |delta_f| <= 10 deg.
PAPER_L2 = ((46.4268, 3.2988), (8.4042, 5.0011), (-75.2145, -6.8793), (-1.1358, -0.1039))
#: Published validity ranges of the two gains (deg), eqs. (61)-(62).
PAPER_L1_RANGE_DEG = (0.0, 80.0)
PAPER_L2_RANGE_DEG = (60.0, 140.0)
#: Sec. 6.2: "The observer gain is switched at 60 degrees of the estimated yaw angle."
PAPER_SWITCH_DEG = 60.0
#: Hysteresis around the paper's switching point (deg); the paper states none for the vehicle.
PAPER_HYSTERESIS_DEG = 0.0
#: A single-gain run counts as converged (for its divergence time) once its error has stayed inside
#: the tolerance for this long (s): it never converges in the sense of :func:`convergence_time`.
SETTLE_HOLD_S = 2.0


def _system(system: ScalarNonlinearSystem | None) -> ScalarNonlinearSystem:
    return cached_design("vehicle_tracking").system if system is None else system


def _gain(system: ScalarNonlinearSystem, L, lo_deg: float, hi_deg: float, index: int) -> RegionGain:
    region = make_region(system, "psi", math.radians(lo_deg), math.radians(hi_deg), index)
    return RegionGain(region=region, L=np.array(L, dtype=float), P=np.eye(system.n), sigma=float("nan"),
                      sigma_max=float("nan"), capped=False, multiplier=float("nan"), lmi_max_eig=float("nan"),
                      bounds=jacobian_bounds(system, region))


def paper_vehicle_design(system: ScalarNonlinearSystem | None = None, *,
                         hysteresis_deg: float = PAPER_HYSTERESIS_DEG) -> tuple[RegionGain, RegionGain]:
    """The paper's switched gains L_1, L_2 (eqs. 61-62), switching at 60 deg (Sec. 6.2).

    Parameters
    ----------
    system : ScalarNonlinearSystem, optional
        The vehicle model (default: the one of the preset design, :func:`.scenarios.cached_design`).
    hysteresis_deg : float
        ``eps``: regions ``[0, 60 + eps]`` and ``[60 - eps, 140]`` deg (see the module docstring).

    Returns
    -------
    (RegionGain, RegionGain)
        Usable as ``gains`` of :class:`~hybobs_opt.observers.switched_gain.SwitchedGainObserver`.
    """
    system = _system(system)
    eps = float(hysteresis_deg)
    if not (math.isfinite(eps) and 0.0 <= eps < PAPER_SWITCH_DEG):
        raise ModelError("hysteresis_deg", f"a hysteresis in [0, {PAPER_SWITCH_DEG:g}) deg", repr(hysteresis_deg))
    return (_gain(system, PAPER_L1, PAPER_L1_RANGE_DEG[0], PAPER_SWITCH_DEG + eps, 0),
            _gain(system, PAPER_L2, PAPER_SWITCH_DEG - eps, PAPER_L2_RANGE_DEG[1], 1))


def paper_single_gain(system: ScalarNonlinearSystem | None = None) -> tuple[RegionGain]:
    """L_1 alone on its published range 0-80 deg (the single-gain observer of Fig. 4)."""
    system = _system(system)
    return (_gain(system, PAPER_L1, *PAPER_L1_RANGE_DEG, 0),)


# ---------------------------------------------------------------------------------------------
# The comparison on the paper's scenario
# ---------------------------------------------------------------------------------------------

@dataclass
class ObserverRecord:
    """Measured behaviour of one observer on the vehicle scenario (times in s, angles in deg).

    Attributes
    ----------
    label : str
    gains : str
        Where the gains come from.
    regions_deg : list of [lo, hi]
    convergence_time : float or None
        :func:`~hybobs_opt.observers.switched_gain.convergence_time` with
        :data:`~.scenarios.CONVERGENCE_TOL` (X, Y, psi): the error stays inside from then on.
    settle_time : float or None
        First time from which the error stays inside the tolerance for :data:`SETTLE_HOLD_S`.
    divergence_time : float or None
        First time after ``settle_time`` at which the error leaves the tolerance (``None``: never).
    true_psi_at_divergence_deg : float or None
    final_abs_error : dict
        ``|error|`` at the last sample per state (model units; psi along the circle).
    max_abs_psi_error_after_deg : float or None
        Largest ``|psi error|`` from ``convergence_time`` on, or from ``settle_time`` on if the
        run never converges (then it includes the divergence).
    switches : list of dict
        ``{"t", "from", "to", "psi_hat_deg"}`` for every region change.
    min_pole_distance : float
        Smallest distance (rad) of the estimated ``delta_f`` to a pole ``pi/2 + k pi`` of
        ``tan`` over the run.
    frozen_stable_up_to_deg : float or None
        Single-gain runs: :func:`frozen_stability_limit` of the gain (``None`` for switched runs).
    true_psi_passes_limit_t : float or None
        When the true yaw first exceeds ``frozen_stable_up_to_deg`` (``None``: never in the run).
    """

    label: str
    gains: str
    regions_deg: list
    convergence_time: float | None
    settle_time: float | None
    divergence_time: float | None
    true_psi_at_divergence_deg: float | None
    final_abs_error: dict
    max_abs_psi_error_after_deg: float | None
    switches: list
    min_pole_distance: float
    frozen_stable_up_to_deg: float | None = None
    true_psi_passes_limit_t: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass
class PaperComparison:
    """The four observers on paper 004's vehicle scenario, and the stated differences from the paper."""

    observers: list[ObserverRecord]
    tolerance: dict
    periodic: dict
    t_final: float
    psi_leaves_deg: dict
    differences: list[str] = field(default_factory=list)

    def record(self, label: str) -> ObserverRecord:
        return next(r for r in self.observers if r.label == label)

    def to_dict(self) -> dict[str, Any]:
        return {"observers": [r.to_dict() for r in self.observers], "tolerance": dict(self.tolerance),
                "periodic": dict(self.periodic), "t_final": self.t_final, "psi_leaves_deg": dict(self.psi_leaves_deg),
                "differences": list(self.differences)}

    def rows(self) -> list[list[str]]:
        """Header and one row per observer (strings)."""

        def f(v, fmt="{:.3f}"):
            return "-" if v is None else fmt.format(v)

        head = ["observer", "regions (deg)", "conv. time (s)", "diverges at (s)", "max |e_psi| after (deg)",
                "final |e| X, Y (m), psi (deg)", "switches t (s) @ psi_hat (deg)", "min dist delta_f to pi/2 (rad)"]
        out = [head]
        for r in self.observers:
            fe = r.final_abs_error
            out.append([
                r.label, ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in r.regions_deg), f(r.convergence_time, "{:.2f}"),
                f(r.divergence_time, "{:.2f}") + ("" if r.true_psi_at_divergence_deg is None
                                                  else f" (psi {r.true_psi_at_divergence_deg:.1f})"),
                f(r.max_abs_psi_error_after_deg, "{:.3g}"),
                f"{fe['X']:.2g}, {fe['Y']:.2g}, {math.degrees(fe['psi']):.2g}",
                "; ".join(f"{s['t']:.2f} @ {s['psi_hat_deg']:.2f}" for s in r.switches if s["t"] >= 1.0) or "-",
                f"{r.min_pole_distance:.3f}"])
        return out

    def table(self) -> str:
        """Plain-text table of the four observers followed by the differences from the paper."""
        rows = self.rows()
        width = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
        lines = ["  ".join(c.ljust(w) for c, w in zip(r, width)).rstrip() for r in rows]
        lines.insert(1, "  ".join("-" * w for w in width))
        lines.append("(switches before t = 1 s, during the initial transient, are left out of the table)")
        lines += ["", "Differences from the paper:"] + [f"- {d}" for d in self.differences]
        return "\n".join(lines)


#: Grid step (deg) of :func:`frozen_stability_limit` and the number of steering angles checked.
FROZEN_GRID_DEG = 0.1
FROZEN_STEER_SAMPLES = 11


def frozen_stability_limit(system: ScalarNonlinearSystem, L, start_deg: float = 0.0) -> float | None:
    """Largest yaw (deg) up to which the frozen error dynamics ``A(x) - L C(x)`` are Hurwitz.

    Walks up from ``start_deg`` on a :data:`FROZEN_GRID_DEG` grid, with every steering angle of
    the box (:data:`FROZEN_STEER_SAMPLES` values) at each yaw; returns the last yaw at which all
    are stable (``None`` if unstable at ``start_deg``; the box's upper end if never unstable).
    This is a local check (eigenvalues at frozen states), not a convergence proof: it says where
    a constant gain *stops* being able to work, which is what the single-gain runs show.
    """
    L = np.asarray(L, dtype=float)
    i_psi, i_d = system.state_names.index("psi"), system.state_names.index("delta_f")
    grid = np.arange(start_deg, math.degrees(system.box_upper[i_psi]) + 1e-9, FROZEN_GRID_DEG)
    steer = np.linspace(system.box_lower[i_d], system.box_upper[i_d], FROZEN_STEER_SAMPLES)
    X = np.tile(0.5 * (system.box_lower + system.box_upper), (grid.size * steer.size, 1))
    X[:, i_psi] = np.repeat(np.radians(grid), steer.size)
    X[:, i_d] = np.tile(steer, grid.size)
    J = system.dynamics_jacobian(X) - np.einsum("ij,kjl->kil", L, system.output_jacobian(X))
    worst = np.max(np.linalg.eigvals(J).real, axis=1).reshape(grid.size, steer.size).max(axis=1)
    bad = np.nonzero(worst >= 0)[0]
    if bad.size == 0:
        return round(float(grid[-1]), 6)
    return None if bad[0] == 0 else round(float(grid[bad[0] - 1]), 6)


def _pole_distance(delta: np.ndarray) -> float:
    """Smallest distance of ``delta`` to a pole ``pi/2 + k pi`` of ``tan``."""
    return float(np.min(np.abs(np.mod(delta, math.pi) - 0.5 * math.pi)))


def _crossing(t: np.ndarray, v: np.ndarray, level: float) -> float | None:
    idx = np.nonzero(v > level)[0]
    return None if idx.size == 0 else float(t[idx[0]])


def _record(label: str, gains_from: str, trace, obs: SwitchedGainObserver, ot, tol: dict) -> ObserverRecord:
    """The metrics of one run (see :class:`ObserverRecord`)."""
    t = trace.t
    names = trace.state_names
    err = obs.difference(ot.x_hat, trace.x)
    idx = [names.index(k) for k in tol]
    tv = np.array([tol[k] for k in tol])
    conv = convergence_time(t, err[:, idx], tv)
    bad = np.any(np.abs(err[:, idx]) > tv[None, :], axis=1)
    dt = float(t[1] - t[0])
    hold = max(1, int(round(SETTLE_HOLD_S / dt)))
    settle = None
    good_run = 0
    for i in range(t.size):
        good_run = 0 if bad[i] else good_run + 1
        if good_run >= hold:
            settle = i - hold + 1
            break
    div = None
    if settle is not None and conv is None:
        later = np.nonzero(bad[settle:])[0]
        div = None if later.size == 0 else int(settle + later[0])
    i_psi = names.index("psi")
    start = None if conv is None and settle is None else (t >= conv if conv is not None else t >= t[settle])
    modes = ot.mode
    switches = [{"t": float(t[i]), "from": int(modes[i - 1]), "to": int(modes[i]),
                 "psi_hat_deg": float(np.degrees(ot.x_hat[i, i_psi]))}
                for i in range(1, modes.size) if modes[i] != modes[i - 1] and modes[i - 1] >= 0]
    rec = ObserverRecord(
        label=label, gains=gains_from,
        regions_deg=[[math.degrees(r.lo), math.degrees(r.hi)] for r in obs.regions],
        convergence_time=conv,
        settle_time=None if settle is None else float(t[settle]),
        divergence_time=None if div is None else float(t[div]),
        true_psi_at_divergence_deg=None if div is None else float(np.degrees(trace.x[div, i_psi])),
        final_abs_error={n: float(abs(err[-1, i])) for i, n in enumerate(names)},
        max_abs_psi_error_after_deg=None if start is None else float(np.degrees(np.max(np.abs(err[start, i_psi])))),
        switches=switches,
        min_pole_distance=_pole_distance(ot.x_hat[:, names.index("delta_f")]),
    )
    if len(obs.regions) == 1:
        lim = frozen_stability_limit(obs.system, obs.gains[0], math.degrees(obs.regions[0].lo))
        rec.frozen_stable_up_to_deg = lim
        rec.true_psi_passes_limit_t = None if lim is None else _crossing(t, np.degrees(trace.x[:, i_psi]), lim)
    return rec


#: Labels of the four observers of :func:`run_paper_comparison`.
PAPER_SWITCHED = "paper L1/L2 switched"
PAPER_SINGLE = "paper L1 alone"
SYNTH_SWITCHED = "synthesised switched"
SYNTH_SINGLE = "synthesised region-1 gain alone"


def run_paper_comparison(t_final: float | None = None) -> PaperComparison:
    """The paper's and the synthesised gains, switched and first gain alone, on the scenario of Sec. 6.2.

    All four observers start from :data:`~.scenarios.VEHICLE_X_HAT0` (Sec. 6.2), wrap the yaw
    modulo 2 pi (:data:`~.scenarios.PERIODIC`) and select the initial region from the first samples
    (switched runs).  Errors of psi are measured along the circle.
    """
    example = "vehicle_tracking"
    design = cached_design(example)
    system = design.system
    trace = get_example(example).scenario(system, t_final)
    dt = float(trace.t[1] - trace.t[0])
    tol = CONVERGENCE_TOL[example]
    periodic = PERIODIC[example]
    runs = (
        (PAPER_SWITCHED, "paper 004 eqs. (61)-(62), switched at 60 deg (Sec. 6.2)", paper_vehicle_design(system)),
        (PAPER_SINGLE, "paper 004 eq. (61) on 0-80 deg", paper_single_gain(system)),
        (SYNTH_SWITCHED, "toolbox LMI synthesis, preset regions (nominal switch 70 deg, epsilon 10 deg)", design.regions),
        (SYNTH_SINGLE, "toolbox LMI synthesis, first region's gain", design.regions[:1]),
    )
    records, periods = [], {}
    for label, source, gains in runs:
        obs = SwitchedGainObserver(system, gains, dt, periodic=periodic)
        obs.reset(np.asarray(VEHICLE_X_HAT0, dtype=float))
        obs.name = label
        ot = obs.run(trace.u, trace.y)
        records.append(_record(label, source, trace, obs, ot, tol))
        periods = {system.state_names[k]: p for k, p in sorted(obs.periodic.items())}
    psi = np.degrees(trace.state("psi"))
    leaves = {f"{lvl:g}": _crossing(trace.t, psi, lvl) for lvl in (PAPER_SWITCH_DEG, 70.0, PAPER_L1_RANGE_DEG[1])}
    res = PaperComparison(records, dict(tol), periods, float(trace.t[-1]), leaves)
    res.differences = _differences(res)
    return res


def _differences(res: PaperComparison) -> list[str]:
    preset = get_preset("vehicle_tracking")
    lv = res.psi_leaves_deg

    def turn_switch(label: str) -> str:
        sw = [s for s in res.record(label).switches if s["t"] >= 1.0]
        return ", ".join(f"t = {s['t']:.2f} s at psi_hat = {s['psi_hat_deg']:.2f} deg" for s in sw) or "none"

    out = [
        f"(a) Switching point: the paper switches 'at 60 degrees of the estimated yaw angle' (Sec. 6.2); the toolbox's "
        f"synthesised design splits 0-140 deg at a nominal {preset.switch_points[0]:g} deg with epsilon = "
        f"{preset.overlap:g} deg (presets.py), so its state machine switches up when the estimate leaves "
        f"[0, {preset.switch_points[0] + preset.overlap:g}] deg. Measured during the turn: paper gains "
        f"{turn_switch(PAPER_SWITCHED)}; synthesised {turn_switch(SYNTH_SWITCHED)} (the true yaw passes 60 deg at "
        f"t = {lv['60']:.2f} s and 80 deg at t = {lv['80']:.2f} s).",
    ]
    for label in (SYNTH_SINGLE, PAPER_SINGLE):
        r = res.record(label)
        lim = r.frozen_stable_up_to_deg
        lim_txt = ("unstable already at the region's lower end" if lim is None else
                   f"its frozen error dynamics A(x) - L C stay Hurwitz up to psi = {lim:.1f} deg"
                   + ("" if r.true_psi_passes_limit_t is None else
                      f", which the true yaw passes at t = {r.true_psi_passes_limit_t:.2f} s")
                   + ("" if r.true_psi_passes_limit_t is not None else
                      " (the true yaw never gets there: the turn ends at 120 deg)"))
        if r.divergence_time is None:
            what = (f"its error never leaves the tolerance after settling at t = {r.settle_time:.2f} s"
                    if r.settle_time is not None else "it never settles into the tolerance")
            what += f" (final |e_psi| = {math.degrees(r.final_abs_error['psi']):.3g} deg)"
        else:
            what = (f"its error first leaves the tolerance after settling at t = {r.divergence_time:.2f} s "
                    f"(true psi {r.true_psi_at_divergence_deg:.1f} deg)")
        out.append(
            f"(b) {label}: {what}; the paper: 'The error grows significantly after the first 15 seconds when the "
            f"orientation exceeds the observer's stable operating regime'. Cause: the turn's yaw rate is not in the "
            f"paper; the scenario assumes {VEHICLE_TURN_RATE_DEG_S:g} deg/s (the turn rate of the study's vehicle scenario), "
            f"chosen so the true yaw leaves 0-80 deg at t = {lv['80']:.2f} s, i.e. at the paper's 15 s. But leaving "
            f"the gain's design range is not where the error grows: {lim_txt}"
            + ("; after that an unstable mode has to grow from the converged error to the tolerance."
               if r.true_psi_passes_limit_t is not None else ", so in this scenario it has no reason to diverge."))
    return out
