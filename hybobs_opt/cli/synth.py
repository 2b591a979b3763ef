"""``hybobs synth SYSTEM --out gains.json [--range ...] [--max-rate R] [--json]``: switched
gains per region, the dwell time ``tau`` and the hysteresis (paper 004); writes and (``--json``)
prints ``regions`` (each with its ``interval``, ``L``, ``P``, ``sigma``, ``sigma_verified`` and the
``decay_search`` log), ``tau``, ``settings``, ``solver_counts`` and ``verification`` (the frozen error
dynamics of every region and the switched observer simulated from several initial errors, with
convergence times: :mod:`hybobs_opt.observers.switched_verification`).  ``--noise-bound NAME=VALUE``
adds ``noise_bound``: the certified ultimate error bound of the switched observer under that
output noise, with the dwell time it needs, and ``noise_design``: gains on the same regions that
minimise that bound at the design's slowest rate and gain bound (:mod:`hybobs_opt.lmi.switched_noise`;
the gains file keeps the synthesised gains).  A hysteresis that does not
enforce the dwell time is an error unless ``--accept-unenforced-dwell`` (then it is in ``warnings``).
Any scalar-nonlinear system: the paper's examples use their published settings, every other
system settings read from the model (:mod:`hybobs_opt.lmi.auto_design`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ..errors import ModelError
from ._common import (add_force_argument, add_system_argument, announce, bound_entries, check_output_path, json_default,
                      print_json)
from ._schedule import add_design_arguments, design_setup, parse_range

HELP = "switched observer gains, dwell time and hysteresis (paper 004)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    add_force_argument(p)
    p.add_argument("--out", "-o", required=True, metavar="FILE", help="gains JSON file (its directory is created if missing)")
    add_design_arguments(p)
    p.add_argument("--max-rate", type=float, default=None, metavar="RATE",
                   help="maximum rate of the scheduling state (unit/s) for the hysteresis")
    p.add_argument("--json", action="store_true", help="print the gains JSON")
    p.add_argument("--accept-unenforced-dwell", action="store_true",
                   help="return a design whose hysteresis does not enforce the dwell time (Theorem 6 not guaranteed)")
    p.add_argument("--no-verify", action="store_true", help="skip the simulation and frozen-Jacobian checks")
    p.add_argument("--periodic", action="append", default=[], metavar="STATE=PERIOD",
                   help="a periodic state (e.g. psi=6.283185307179586) the verification's observer wraps")
    p.add_argument("--noise-bound", action="append", metavar="NAME=VALUE", dest="noise_bound",
                   help="bound on an output's noise in its units (repeatable; a bare VALUE bounds every output): "
                        "also certify the switched observer's ultimate error bound under that noise")


def run(args: argparse.Namespace) -> int:
    """``hybobs synth``: switched gains, dwell time and hysteresis, written to ``--out``."""
    announce(args, "loading the LMI solvers (numpy, cvxpy, Clarabel)")
    import dataclasses
    import warnings

    from ..lmi.auto_design import design_switched
    from ..lmi.solve import counting_solves
    from ..lmi.switched import DwellTimeWarning
    from ..progress import counter_bar
    from ..studies.paper004_nonmonotonic.presets import preset_design

    if args.max_rate is not None and not (math.isfinite(args.max_rate) and args.max_rate > 0):
        raise ModelError("--max-rate", "a positive rate of the scheduling state (its unit per second)", repr(args.max_rate))
    if args.periodic and args.no_verify:
        raise ModelError("--periodic", "no value with --no-verify (the verification's observer wraps the periodic states)",
                         repr(args.periodic[0]))
    check_output_path("--out", args.out, args.force, create_parents=True)
    named, preset, settings = design_setup(args)
    system = named.system
    periodic = _periodic(args.periodic, system)
    noise = None if not args.noise_bound else bound_entries(args.noise_bound, tuple(system.output_names),
                                                            "--noise-bound", "noise_bound", "output")
    accept = bool(args.accept_unenforced_dwell)
    update, close = counter_bar(not args.json, "LMI solves", "solve")
    try:
        with warnings.catch_warnings(), counting_solves(None if update is None else (lambda n: update(n, None))):
            warnings.simplefilter("ignore", DwellTimeWarning)  # reported in the JSON and printed below
            if preset is not None:
                lo, hi = parse_range(args.range, preset, system.state_names, system) if args.range else preset.synth_range
                design = preset_design(named.example.name, system, lo, hi, rate=args.max_rate,
                                       accept_unenforced_dwell=accept)
                unit, factor = preset.unit, preset.factor
            else:
                lo, hi, unit, factor = settings.lo, settings.hi, "", 1.0
                design = design_switched(system, settings, accept_unenforced_dwell=accept)
    finally:
        close()
    if not args.no_verify:
        from ..observers.switched_verification import verify_switched_design

        scenario, name = None, None
        if named.example is not None and preset is not None:
            from ..studies.paper004_nonmonotonic.scenarios import PERIODIC

            scenario, name = named.example.scenario(system), f"the paper's scenario of {named.example.name}"
            periodic = periodic or PERIODIC.get(named.example.name)
        design = dataclasses.replace(design, verification=verify_switched_design(design, scenario, scenario_name=name,
                                                                                  periodic=periodic))
    snb = snd = None
    if noise is not None:
        snb, snd = _noise_bounds(design, noise, preset, settings, args.json)
    out = design.to_dict(unit, factor)
    if snb is not None:
        out["noise_bound"] = snb.to_dict(unit, factor)
        out["noise_design"] = snd.to_dict(unit, factor)
    out["example"] = named.label
    out["system_label"] = named.label
    out["range"] = [lo, hi]
    out["settings"] = {"source": "paper"} if settings is None else {"source": "model", **settings.to_dict()}
    path = Path(args.out)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    from ..lmi.gains_file import save_gains

    out = save_gains(path, out, system, default=json_default)  # format version, fingerprint, checksum
    out["written"] = str(path)
    if args.json:
        print_json(out)
        return 0
    u = unit
    for text in design.warnings:
        print(f"warning: {text}", file=sys.stderr)
    print(f"{named.label}: {len(design.regions)} regions of {design.coordinate_name}, {design.solves} LMI solves, {design.seconds:.2f} s")
    for r in out["regions"]:
        print(f"  [{r['interval'][0]:8.3f}, {r['interval'][1]:8.3f}] {u}  sigma = {r['sigma']:.4g} 1/s "
              f"(max {r['sigma_max']:.4g})  ||L|| = {r['gain_norm']:.4g}")
    print(f"dwell time tau = {design.tau:.4g} s (fixed per-region P: {design.tau_fixed:.4g} s)")
    if out["epsilon_required"] is not None:
        print(f"hysteresis needed at {out['max_rate']:.4g} {u}/s: epsilon >= {out['epsilon_required']:.4g} {u} "
              f"(regions built with {out['epsilon']:.4g} {u}; dwell enforced: {out['dwell_enforced']})")
    v = design.verification
    if v is not None:
        sim = v.simulation
        print(f"verification: frozen error dynamics max Re(lambda) = {v.max_real_eig:.4g} 1/s over the regions; "
              f"{sim.scenario}: converged from {sum(t is not None for t in sim.convergence_times)}/"
              f"{len(sim.convergence_times)} initial errors"
              + (f", worst convergence time {sim.worst_convergence_time:.4g} s" if sim.converged else ""))
        for note in v.notes:
            print(f"warning: {note}", file=sys.stderr)
    if snb is not None:
        print(f"noise, synthesised gains: {snb.claim()}")
        print(f"noise, gains designed for it (decay rate >= {min(r.sigma for r in design.regions):.4g} 1/s): "
              f"{snd.claim()}")
    print(f"gains written to {path}")
    return 0


def _noise_bounds(design, noise: dict, preset, settings, quiet: bool):
    """The certified bounds under ``noise`` (by output name) of the design's gains and of gains designed for it."""
    from ..contract import noise_bound_vector
    from ..lmi.switched_noise import switched_noise_bound
    from ..progress import counter_bar
    from ..studies.paper004_nonmonotonic.presets import scaling_for

    system = design.system
    scaling = scaling_for(preset, system) if preset is not None else settings.scaling
    vbar = noise_bound_vector(noise, system.output_names)
    update, close = counter_bar(not quiet, "noise SDPs", "SDP")
    tick = None if update is None else (lambda n: update(n, None))
    try:
        given = switched_noise_bound(design, vbar, reference=scaling, scaling=scaling, progress=tick)
        designed = switched_noise_bound(design, vbar, reference=scaling, scaling=scaling, design_gains=True,
                                        gain_bound=design.gain_bound, min_decay=min(r.sigma for r in design.regions),
                                        progress=tick)
    finally:
        close()
    return given, designed


def _periodic(items: list[str], system) -> dict[str, float] | None:
    """``--periodic STATE=PERIOD`` options as a mapping (validated by the observer)."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            period = float(value)
        except ValueError:
            period = float("nan")
        if not sep or name not in system.state_names or not (math.isfinite(period) and period > 0):
            raise ModelError("--periodic", f"STATE=PERIOD with STATE one of {system.state_names} and a positive period",
                             repr(item))
        if name in out:
            raise ModelError("--periodic", f"each state once ({name} is given twice)", repr(item))
        out[name] = period
    return out or None
