"""``hybobs synth EXAMPLE --out gains.json [--range ...] [--max-rate R] [--json]``: switched
gains per region, the dwell time ``tau`` and the hysteresis (paper 004); writes and (``--json``)
prints ``regions`` (each with its ``interval``, ``L``, ``P``, ``sigma``) and ``tau``.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from ..errors import ModelError
from ._common import json_default, print_json
from ._schedule import example_and_preset, parse_range

HELP = "switched observer gains, dwell time and hysteresis (paper 004)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("example", help="vehicle_tracking or magnetic_piston")
    p.add_argument("--out", required=True, metavar="FILE", help="gains JSON file")
    p.add_argument("--range", metavar="NAME=LO:HI", help="range of the scheduling state (default: the preset's)")
    p.add_argument("--max-rate", type=float, default=None, metavar="R",
                   help="maximum rate of the scheduling state (unit/s) for the hysteresis")
    p.add_argument("--json", action="store_true", help="print the gains JSON")


def run(args: argparse.Namespace) -> int:
    """``hybobs synth``: switched gains, dwell time and hysteresis, written to ``--out``."""
    from ..studies.paper004_nonmonotonic.presets import preset_design

    example, preset = example_and_preset(args.example)
    system = example.build()
    lo, hi = parse_range(args.range, preset, system.state_names) if args.range else preset.synth_range
    if args.max_rate is not None and not (math.isfinite(args.max_rate) and args.max_rate > 0):
        raise ModelError("--max-rate", f"a positive rate of {preset.coordinate} in {preset.unit}/s", repr(args.max_rate))
    design = preset_design(example.name, system, lo, hi, rate=args.max_rate)
    out = design.to_dict(preset.unit, preset.factor)
    out["example"] = example.name
    out["range"] = [lo, hi]
    path = Path(args.out)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2, default=json_default))
    out["written"] = str(path)
    if args.json:
        print_json(out)
        return 0
    u = preset.unit
    print(f"{example.name}: {len(design.regions)} regions of {preset.coordinate}, {design.solves} LMI solves, {design.seconds:.2f} s")
    for r in out["regions"]:
        print(f"  [{r['interval'][0]:8.3f}, {r['interval'][1]:8.3f}] {u}  sigma = {r['sigma']:.4g} 1/s "
              f"(max {r['sigma_max']:.4g})  ||L|| = {r['gain_norm']:.4g}")
    print(f"dwell time tau = {design.tau:.4g} s (fixed per-region P: {design.tau_fixed:.4g} s)")
    if out["epsilon_required"] is not None:
        print(f"hysteresis needed at {out['max_rate']:.4g} {u}/s: epsilon >= {out['epsilon_required']:.4g} {u} "
              f"(regions built with {out['epsilon']:.4g} {u}; dwell enforced: {out['dwell_enforced']})")
    print(f"gains written to {path}")
    return 0
