"""``hybobs synth SYSTEM --out gains.json [--range ...] [--max-rate R] [--json]``: switched
gains per region, the dwell time ``tau`` and the hysteresis (paper 004); writes and (``--json``)
prints ``regions`` (each with its ``interval``, ``L``, ``P``, ``sigma``), ``tau``, ``settings``
and ``warnings`` (a hysteresis that does not enforce the dwell time is one, also printed).
Any scalar-nonlinear system: the paper's examples use their published settings, every other
system settings read from the model (:mod:`hybobs_opt.lmi.auto_design`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from ..errors import ModelError
from ._common import add_system_argument, json_default, print_json
from ._schedule import add_design_arguments, design_setup, example_and_preset, parse_range  # noqa: F401

HELP = "switched observer gains, dwell time and hysteresis (paper 004)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--out", required=True, metavar="FILE", help="gains JSON file")
    add_design_arguments(p)
    p.add_argument("--max-rate", type=float, default=None, metavar="R",
                   help="maximum rate of the scheduling state (unit/s) for the hysteresis")
    p.add_argument("--json", action="store_true", help="print the gains JSON")


def run(args: argparse.Namespace) -> int:
    """``hybobs synth``: switched gains, dwell time and hysteresis, written to ``--out``."""
    import warnings

    from ..lmi.auto_design import design_switched
    from ..lmi.switched import DwellTimeWarning
    from ..studies.paper004_nonmonotonic.presets import preset_design

    if args.max_rate is not None and not (math.isfinite(args.max_rate) and args.max_rate > 0):
        raise ModelError("--max-rate", "a positive rate of the scheduling state (its unit per second)", repr(args.max_rate))
    named, preset, settings = design_setup(args)
    system = named.system
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DwellTimeWarning)  # reported in the JSON and printed below
        if preset is not None:
            lo, hi = parse_range(args.range, preset, system.state_names) if args.range else preset.synth_range
            design = preset_design(named.example.name, system, lo, hi, rate=args.max_rate)
            unit, factor = preset.unit, preset.factor
        else:
            lo, hi, unit, factor = settings.lo, settings.hi, "", 1.0
            design = design_switched(system, settings)
    out = design.to_dict(unit, factor)
    out["example"] = named.label
    out["system_label"] = named.label
    out["range"] = [lo, hi]
    out["settings"] = {"source": "paper"} if settings is None else {"source": "model", **settings.to_dict()}
    path = Path(args.out)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2, default=json_default))
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
    print(f"gains written to {path}")
    return 0
