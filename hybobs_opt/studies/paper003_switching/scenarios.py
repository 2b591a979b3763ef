"""Paper 003's observer study: the gains (20a-b) of the T-junction, the drift observer (18) on
the paper's scenarios (Fig. 3) with the paper's, deadbeat and positive gains, and
``hybobs observe traffic_junction / switching_server``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.observers.drift_observer import DriftObserver
from hybobs_opt.synthesis.periodic_gains import (
    PeriodicGains,
    analyse_gains,
    deadbeat_gains,
    positive_deadbeat_gains,
    positive_observer,
)
from hybobs_opt.systems.event_sampled import PeriodicSystem, periodic_system

from .systems import (
    JUNCTION_ESTIMATE_MODE,
    JUNCTION_ESTIMATE_X_BAR,
    JUNCTION_OBSERVER_START,
    switching_server,
    switching_server_scenario,
    traffic_junction,
    traffic_junction_scenario,
)

# ---------------------------------------------------------------------------- the paper's gains
def junction_paper_gains(lam: Sequence[float], mu: Sequence[float]) -> np.ndarray:
    """Gains (20a-b) of paper 003, Section 5: ``L1 = [0, lam2, lam3]``, ``L2 = [lam1, lam2 lam3 / mu3, 0]``.

    For the 3-flow T-junction with the sensor on lane 1 (phase 1 = serving flow 1, phase 2 = the
    rest of the cycle).
    """
    l1, l2, l3 = (float(v) for v in lam)
    m3 = float(mu[2])
    return np.array([[0.0, l2, l3], [l1, l2 * l3 / m3, 0.0]])


# ---------------------------------------------------------------------------- CLI scenarios
#: Observer kinds of ``hybobs observe traffic_junction|switching_server --observers KIND``;
#: append ``+projection`` for Remark 4.4's projected estimate.
OBSERVER_KINDS = ("paper", "deadbeat", "positive", "positive-deadbeat")

#: The switching-server observer's initial estimate of the buffers ``[x1, x2]`` at ``t = 0`` in mode 1
#: with ``x0^ = alpha_Q`` (the paper's initialisation convention, Section 4.2).  Paper 003 runs no
#: server scenario; empty buffers are chosen here as "no knowledge".
SERVER_ESTIMATE_X_BAR: tuple[float, float] = (0.0, 0.0)


def scenario_gains(kind: str, ps: PeriodicSystem, example: str, params: dict | None = None) -> PeriodicGains:
    """The gains of an observer kind for the scenario of ``example`` (see :data:`OBSERVER_KINDS`)."""
    if kind == "paper":
        if example != "traffic_junction":
            raise ModelError("--observers", "deadbeat, positive or positive-deadbeat (paper 003 prints gains "
                                           "only for the T-junction)", repr(kind))
        p = params or {}
        return analyse_gains(ps, junction_paper_gains(p.get("lam", (1.0, 2.0, 3.0)), p.get("mu", (8.0, 10.0, 12.0))),
                             "paper (20a-b)")
    if kind == "deadbeat":
        return deadbeat_gains(ps)
    if kind == "positive":
        return positive_observer(ps)
    if kind == "positive-deadbeat":
        return positive_deadbeat_gains(ps)
    raise ModelError("--observers", f"one of {OBSERVER_KINDS} (optionally with +projection)", repr(kind))


def run_drift_scenario(example: str, kind: str | None = None, *, project: bool = False) -> dict[str, Any]:
    """Run the observer of ``kind`` on the paper scenario of ``example``; everything the CLI and report need.

    ``traffic_junction``: the true junction of Section 5 (``x(0) = [5, 40, 60, 0]``, see
    :data:`.systems.JUNCTION_X0_BAR`), observer from ``t = 50`` with
    ``x^(50) = [0, 70, 20, 30]`` in mode 4; default gains (20a-b).  ``switching_server``: the
    server scenario of Section 2.1, observer from ``t = 0`` with ``x^(0) = [gamma1, 0, 0]`` in
    mode 1; default gains from :func:`~hybobs_opt.synthesis.periodic_gains.deadbeat_gains`.

    Returns
    -------
    dict
        ``system``, ``trace`` (truth), ``gains``, ``observer``, ``out`` (ObserverTrace on the
        rows from the start time), ``t``, ``x_true`` and ``summary`` (JSON-ready).
    """
    if example == "traffic_junction":
        system = traffic_junction()
        trace = traffic_junction_scenario(system)
        t0, q0 = JUNCTION_OBSERVER_START, JUNCTION_ESTIMATE_MODE
        x0 = np.array([0.0, *JUNCTION_ESTIMATE_X_BAR])
        kind = kind or "paper"
    elif example == "switching_server":
        system = switching_server()
        trace = switching_server_scenario(system)
        t0, q0 = 0.0, 1
        x0 = np.array([system.alpha[-1], *SERVER_ESTIMATE_X_BAR])
        kind = kind or "deadbeat"
    else:
        raise ModelError("example", "traffic_junction or switching_server", repr(example))
    ps = periodic_system(system)
    gains = scenario_gains(kind, ps, example)
    obs = DriftObserver(system, gains, project=project)
    obs.reset(x0, t0=t0, q0=q0)
    keep = trace.t >= t0
    out = obs.run_trace(trace, t0)
    x_true = trace.x[keep]
    t = trace.t[keep]
    err = out.x_hat - x_true
    summary: dict[str, Any] = {
        "example": example,
        "observer": kind + ("+projection" if project else ""),
        "paper": "003",
        "state_names": list(system.state_names),
        "gains": gains.to_dict(),
        "observer_start": t0,
        "x_hat_start": x0.tolist(),
        "mode_start": q0,
        "visible_events": [r.to_dict() for r in obs.events],
        "t_final": float(t[-1]),
        "final_error": err[-1].tolist(),
        "final_abs_error_queues": float(np.max(np.abs(err[-1, 1:]))),
        "min_queue_estimate": float(out.x_hat[:, 1:].min()),
        "nonnegative": bool(out.x_hat[:, 1:].min() >= 0.0),
        "flags": out.flag_counts(),
        **out.timing(),
    }
    exact = [r.t for r in obs.events if np.max(np.abs(r.x_after[1:] - _true_at(trace, r.t)[1:])) <= 1e-6 * (1.0 + np.abs(r.x_after).max())]
    summary["first_exact_visible_event"] = exact[0] if exact else None
    return {"system": system, "trace": trace, "gains": gains, "observer": obs, "out": out, "t": t, "x_true": x_true,
            "summary": summary}


def _true_at(trace, t: float) -> np.ndarray:
    """True state just after time ``t`` (the last row stamped ``t``)."""
    idx = np.nonzero(np.isclose(trace.t, t, rtol=0, atol=1e-12))[0]
    if idx.size:
        return trace.x[idx[-1]]
    return np.array([np.interp(t, trace.t, trace.x[:, i]) for i in range(trace.x.shape[1])])


#: The quantity of the states ``x1 ... xN`` of each example and its unit (Secs. 2.1 and 5; the paper
#: gives no units: jobs and vehicles, counted).
PLOTTED_QUANTITY = {"switching_server": ("buffer content", "jobs"), "traffic_junction": ("queue length", "vehicles")}


def plot_drift_run(res: dict[str, Any], path, title: str = "") -> None:
    """Figure 3 of paper 003: true (dashed) and estimated (solid) queues, visible events marked."""
    from hybobs_opt.plotting import pyplot

    plt = pyplot()

    names = res["system"].state_names
    t, xt, xh = res["t"], res["x_true"], res["out"].x_hat
    fig, ax = plt.subplots(figsize=(8.2, 3.6))
    for i in range(1, len(names)):
        line, = ax.plot(t, xh[:, i], lw=1.3, label=f"{names[i]}^")
        ax.plot(t, xt[:, i], "--", lw=1.0, color=line.get_color(), label=f"{names[i]}")
    for r in res["observer"].events:
        ax.axvline(r.t, color="k", lw=0.5, alpha=0.4)
    ax.set_xlabel("t [s]")
    quantity, unit = PLOTTED_QUANTITY.get(res["summary"].get("example"), ("x1 ... xN", ""))
    ax.set_ylabel(f"{quantity} [{unit}]" if unit else quantity)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)  # beside: no line hidden
    ax.set_title(title or f"{res['summary']['example']}: observer (18), {res['summary']['observer']}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _cli_scenario(example: str):
    def scenario(args) -> dict[str, Any]:
        kind = getattr(args, "observer", None)
        project = False
        if kind and kind.endswith("+projection"):
            kind, project = kind[: -len("+projection")], True
        res = run_drift_scenario(example, kind, project=project)
        out = res["summary"]
        if getattr(args, "plot", None):
            plot_drift_run(res, args.plot)
            out["plot"] = args.plot
        return out

    return scenario


#: The study's scenario runner under the name every study uses.
run_scenario = run_drift_scenario


def register_scenarios(register) -> None:
    """``hybobs observe traffic_junction / switching_server``."""
    for name in ("traffic_junction", "switching_server"):
        register(name, _cli_scenario(name))
