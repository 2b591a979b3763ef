"""The certified radii of the set-membership observer and of the lookup table under bounded noise: do they hold, how often is a step flagged, what
does a step cost against the MIQP moving-horizon observer.

Run ``python -m benchmarks.bench_set_membership`` (full, several minutes) or ``--quick`` (results
in ``benchmarks/results/quick/``).  Writes ``benchmarks/results/set_membership.json``:

* **coverage**: on four PWA systems -- model (16) of paper 002 on its backlash scenario, model (17)
  on its own, the dead-zone spring of the tests (``tests/canonical.py``, Nordin & Gutman 2002) and the rotation system
  with ``y = x2`` (Bemporad & Morari 1999) -- noise-free and with uniform output noise at the
  stated bound (0.1 % and 1 % of the output range): the number of steps whose true state lies
  outside the stated radius (must be 0), the flag counts and the radii's median and largest
  value per state, for :class:`~hybobs_opt.mhe.SetMembershipObserver` (exact box, MILPs),
  :class:`~hybobs_opt.mhe.MHEObserver` with ``noise_bound`` (the MIQP optimum, with the radius of
  the exact box around it; not on model (17), see :data:`MIQP_BOUNDED_MAX_STATES`) and
  :class:`~hybobs_opt.observers.NoiseAwareLookupObserver` with ``noise_bound`` (outer box, one
  table product; where ``T p >= n``).  On the rotation system every state has a mirror image with
  the same outputs: a step is flagged only when the mirror is within the tolerance.
* **timing**: per-step median of :class:`~hybobs_opt.mhe.SetMembershipObserver`, of the MIQP with
  ``noise_bound`` and of the bounded-noise lookup against :class:`~hybobs_opt.mhe.MHEObserver`
  (norm 2, the default, no radius) on model (16) at T = 3 and 5, the
  same samples, one run (ratios, not absolute speed).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from tests.canonical import deadzone_drive, deadzone_spring

from ._machine import json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
#: The MIQP with a noise bound runs on the systems with at most this many states: on model (17)
#: (five states) its MIQP alone takes about 0.7 s per step at T = 3, and its box is the
#: set-membership observer's, measured beside it.
MIQP_BOUNDED_MAX_STATES = 3
MODELS = Path(__file__).resolve().parents[1] / "examples" / "models"


def _cases(steps: int) -> dict:
    """``name -> (system, U, X, Y)`` noise-free runs of ``steps`` samples."""
    from hybobs_opt import get_example, simulate_pwa
    from hybobs_opt.studies.paper002_powertrain.systems import backlash_torque_profile
    from hybobs_opt.systems import load_model

    out = {}
    p16 = get_example("powertrain3").build()
    start = 600  # through the first change of contact (sample 1,014)
    U = backlash_torque_profile(np.arange(start + steps) * p16.Ts)[:, None]
    tr = simulate_pwa(p16, np.array([0.06, 39.0, 3.25]), U)
    out["model16"] = (p16, U[start:], tr.x[start:], tr.y[start:])
    p17 = get_example("powertrain5").build()
    ex = get_example("powertrain5")
    sc = ex.scenario(p17)
    n17 = min(steps, len(sc.u))
    out["model17"] = (p17, np.asarray(sc.u, float).reshape(len(sc.u), -1)[:n17], np.asarray(sc.x)[:n17],
                      np.asarray(sc.y, float).reshape(len(sc.u), -1)[:n17])
    spring = deadzone_spring()
    U = deadzone_drive(steps)
    tr = simulate_pwa(spring, np.array([0.3, 0.0]), U)
    out["deadzone_spring"] = (spring, U, tr.x, tr.y)
    rot = load_model(MODELS / "bemporad_morari_rotation.toml")
    U = np.random.default_rng(0).uniform(-1, 1, size=(steps, 1))
    tr = simulate_pwa(rot, np.array([3.0, -2.0]), U)
    out["rotation_y_x2"] = (rot, U, tr.x, tr.y)
    return out


def _observers(system, T: int, beta, analyses: dict) -> dict:
    """The observers with radii: the set-membership MILPs, the MIQP moving-horizon observer with a
    noise bound (its optimum, with the radius of the consistent box around it) and the lookup table
    under bounded noise."""
    from hybobs_opt import MHEObserver
    from hybobs_opt.mhe import SetMembershipObserver
    from hybobs_opt.observers import NoiseAwareLookupObserver
    from hybobs_opt.regions import analyse_observability

    out = {"set_membership": SetMembershipObserver(system, T, beta)}
    if system.n <= MIQP_BOUNDED_MAX_STATES:
        out["miqp_bounded"] = MHEObserver(system, T, noise_bound=beta)
    if T * system.p >= system.n:
        key = (system.name, T)
        if key not in analyses:
            analyses[key] = analyse_observability(system, T)
        out["lookup_bounded"] = NoiseAwareLookupObserver(analyses[key], noise_bound=beta)
    return out


def coverage(steps: int, T: int, log) -> dict:
    from hybobs_opt.systems.ranges import output_range

    table = {}
    rng = np.random.default_rng(2026)
    analyses: dict = {}
    for name, (system, U, X, Y) in _cases(steps).items():
        lo, hi = output_range(system)
        for level in (0.0, 0.001, 0.01):
            beta = level * (hi - lo)
            Yn = Y + rng.uniform(-1.0, 1.0, size=Y.shape) * beta
            for kind, obs in _observers(system, T, beta, analyses).items():
                t0 = time.perf_counter()
                run = obs.run(U, Yn)
                seconds = time.perf_counter() - t0
                R = run.radii()
                R = np.full(run.x_hat.shape, np.nan) if R is None else R
                has = np.all(np.isfinite(R), axis=1)
                outside = run.n_outside_radius(X)
                flags = {f: int(np.count_nonzero(run.flags == f)) for f in ("observable", "unobservable", "fallback", "warming_up")}
                key = f"{name} T={T} noise={level:g} {kind}"
                table[key] = {"observer": kind, "system": name, "noise_level": level, "samples": int(len(U)),
                              "noise_bound": beta.tolist(), "n_outside_radius": outside, "flags": flags,
                              "radius_median": np.nanmedian(R, axis=0).tolist() if has.any() else None,
                              "radius_max": np.nanmax(R, axis=0).tolist() if has.any() else None,
                              "tolerance": np.asarray(
                                  getattr(obs, "tolerance", None) if kind != "miqp_bounded" else
                                  obs.settings.uniqueness_delta * system.scales()[0][:system.n]).tolist(),
                              "seconds_per_step": seconds / len(U)}
                log(f"{key}: outside {outside}, flags {flags}, {1e3 * seconds / len(U):.2f} ms/step")
    return table


def timing(steps: int, log) -> dict:
    from hybobs_opt import MHEObserver, get_example, simulate_pwa
    from hybobs_opt.mhe import SetMembershipObserver
    from hybobs_opt.observers import NoiseAwareLookupObserver
    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.studies.paper002_powertrain.systems import backlash_torque_profile

    plant = get_example("powertrain3").build()
    U = backlash_torque_profile(np.arange(800 + steps) * plant.Ts)[:, None]
    tr = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    U, Y = U[800:], tr.y[800:]
    out = {}
    for T in (3, 5):
        rec = {}
        analysis = analyse_observability(plant, T)
        for name, make in (("miqp", lambda: MHEObserver(plant, T)),
                           ("set_membership", lambda: SetMembershipObserver(plant, T, 0.0)),
                           ("miqp_bounded", lambda: MHEObserver(plant, T, noise_bound=0.0)),
                           ("lookup_bounded", lambda: NoiseAwareLookupObserver(analysis, noise_bound=0.0))):
            run = make().run(U, Y)
            secs = [s for s, f in zip(run.seconds, run.flags) if f != "warming_up"]
            rec[name] = {"median_step_s": statistics.median(secs), "flagged_observable": int(np.count_nonzero(run.flags == "observable")),
                         "steps": int(len(U))}
        rec["ratio_set_membership_to_miqp"] = rec["set_membership"]["median_step_s"] / rec["miqp"]["median_step_s"]
        rec["ratio_miqp_bounded_to_miqp"] = rec["miqp_bounded"]["median_step_s"] / rec["miqp"]["median_step_s"]
        rec["ratio_lookup_bounded_to_miqp"] = rec["lookup_bounded"]["median_step_s"] / rec["miqp"]["median_step_s"]
        out[f"T={T}"] = rec
        log(f"timing T={T}: {rec}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_set_membership", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="60 samples per case (smoke test); results in results/quick/")
    args = parser.parse_args(argv)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    steps = 60 if args.quick else 650  # 4 systems x 2 noise levels x 650 = 5,200 noisy samples
    t0 = time.perf_counter()

    def log(msg: str) -> None:
        print(f"[bench_set_membership] {msg} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    record = {
        "benchmark": "set_membership",
        "quick": args.quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "versions": versions(("hybobs_opt", "numpy", "scipy", "highspy", "daqp")),
        "coverage": coverage(steps, 3, log),
        "timing": timing(40 if args.quick else 200, log),
    }
    for kind in ("set_membership", "miqp_bounded", "lookup_bounded"):
        rows = [r for r in record["coverage"].values() if r["observer"] == kind]
        record[f"{kind}_total_outside_radius"] = sum(r["n_outside_radius"] for r in rows)
        record[f"{kind}_total_samples"] = sum(r["samples"] for r in rows)
        record[f"{kind}_noisy_samples"] = sum(r["samples"] for r in rows if r["noise_level"] > 0)
    record["seconds"] = time.perf_counter() - t0
    path = out_dir / "set_membership.json"
    path.write_text(json.dumps(record, indent=1, default=json_default) + "\n")
    log(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
