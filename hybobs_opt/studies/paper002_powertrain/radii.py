"""Certified radii on the scenario of model (16): the observers under a stated bound on the output noise.

The scenario of Section 7 of paper 002 with uniform noise on the engine speed at a stated bound
``beta`` (``|noise| <= beta``, the assumption of set-membership estimation: Schweppe 1968;
Bemporad, Mignone & Morari, ACC 1999, for the PWA / MLD case).  Three observers state a radius
per state that holds whenever the data satisfy the bound:

* ``set_membership`` -- :class:`~hybobs_opt.mhe.SetMembershipObserver`: the exact box of the
  states consistent with the window, its centre as the estimate;
* ``miqp_bounded`` -- :class:`~hybobs_opt.mhe.MHEObserver` with ``noise_bound``: the MIQP's
  optimum, with the distance to the farther side of the same box;
* ``lookup_bounded`` -- :class:`~hybobs_opt.observers.NoiseAwareLookupObserver` with
  ``noise_bound``: an outer box from the lookup tables.

The study counts the steps whose true state lies outside the stated radius (must be 0), the
flags, the radii's median and largest value per state, and the per-step time.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.defaults import MHE_UNIQUENESS_DELTA

__all__ = ["RADIUS_OBSERVERS", "run_radius_study"]

#: Observers of the study, in table order.
RADIUS_OBSERVERS = ("set_membership", "miqp_bounded", "lookup_bounded")


def run_radius_study(bound: float, steps: int, *, horizon: int = 3, seed: int = 0,
                     traces: dict | None = None) -> dict[str, Any]:
    """Run the study (module docstring) on model (16) and return its JSON-ready table.

    Parameters
    ----------
    bound : float
        Bound on the noise of the engine speed [rad/s]; the noise is uniform in ``[-bound, bound]``.
    steps : int
        Samples of the scenario (1 ms each).
    horizon : int, default 3
        Window length of the three observers.
    seed : int, default 0
        Seed of the noise.
    traces : dict, optional
        Filled with ``"truth"`` (the simulated trace) and one
        :class:`~hybobs_opt.contract.ObserverTrace` per observer.

    Returns
    -------
    dict
        ``{"bound", "steps", "horizon", "state_names", "observers": {name: record}}``.
    """
    from hybobs_opt.mhe import MHEObserver, SetMembershipObserver
    from hybobs_opt.observers import NoiseAwareLookupObserver

    from .bench import bench_trace

    if not (isinstance(bound, (int, float)) and np.isfinite(bound) and bound >= 0):
        raise ModelError("bound", "a non-negative finite noise bound [rad/s]", repr(bound))
    plant, trace, _, analysis = bench_trace("powertrain3", horizon, steps, 0.0, seed)
    y = trace.y + np.random.default_rng(seed).uniform(-bound, bound, size=trace.y.shape)
    if traces is not None:
        traces["truth"] = trace
    half = plant.scales()[0][:plant.n]
    names = tuple(plant.state_names)
    make = {"set_membership": lambda: SetMembershipObserver(plant, horizon, bound),
            "miqp_bounded": lambda: MHEObserver(plant, horizon, noise_bound=bound),
            "lookup_bounded": lambda: NoiseAwareLookupObserver(analysis, noise_bound=bound)}
    observers: dict[str, Any] = {}
    for name in RADIUS_OBSERVERS:
        obs = make[name]()
        run = obs.run(trace.u, y)
        if traces is not None:
            traces[name] = run
        R = run.radii()
        if R is None:
            R = np.full(run.x_hat.shape, np.nan)
        has = np.all(np.isfinite(R), axis=1)
        err = np.abs(run.x_hat - trace.x)
        flags = run.flag_counts()
        flagged = (run.flags == "observable") & has
        secs = [s for s, f in zip(run.seconds, run.flags) if f != "warming_up"]
        observers[name] = {
            "flags": flags,
            "n_with_radius": int(has.sum()),
            "n_outside_radius": run.n_outside_radius(trace.x),
            "radius_median": dict(zip(names, np.median(R[has], axis=0).tolist())) if has.any() else None,
            "radius_median_flagged": dict(zip(names, np.median(R[flagged], axis=0).tolist())) if flagged.any() else None,
            "max_abs_error_flagged": dict(zip(names, err[flagged].max(axis=0).tolist())) if flagged.any() else None,
            "median_step_s": float(np.median(secs)) if secs else None,
        }
    return {"example": "powertrain3", "bound": float(bound), "steps": int(steps), "horizon": int(horizon),
            "state_names": list(names), "tolerance": dict(zip(names, (MHE_UNIQUENESS_DELTA * half).tolist())), "observers": observers}
