"""``hybobs diagnose`` and ``hybobs synth``: the LMI commands of paper 004 (added via ``add_commands``).

* ``hybobs diagnose EXAMPLE [--range psi=0:360] [--out DIR] [--json]`` -- is there a constant
  observer gain on the range?  Writes a Markdown and an HTML report (verdict, certificate,
  Jacobian-bound plots, what to do next) into ``DIR`` and prints the verdict; ``--json`` prints
  ``feasible`` and, when infeasible, ``certificate`` with ``verified``, ``reason`` and ``theorem``.
* ``hybobs synth EXAMPLE --out gains.json [--range ...] [--max-rate R] [--json]`` -- switched
  gains per region, the dwell time ``tau`` and the hysteresis; writes and (``--json``) prints
  ``regions`` (each with its ``interval``, ``L``, ``P``, ``sigma``) and ``tau``.

Ranges and rates are in the preset's display unit of the coordinate (degrees for ``psi``, mm for
``z``); ``psi=0:6.28rad`` gives radians explicitly.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

from ..errors import ModelError

DEFAULT_DIAGNOSE_OUT = "out/diagnose"

_RANGE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:]+):([^:]+?)\s*(deg|rad)?\s*$")


def parse_range(text: str, preset, state_names: tuple[str, ...]) -> tuple[float, float]:
    """``NAME=LO:HI[deg|rad]`` -> ``(lo, hi)`` in the preset's display units.

    Raises
    ------
    ModelError
        Malformed text, a coordinate other than the preset's scheduling state, non-numbers,
        non-finite values, or ``LO >= HI`` (lower bound above upper bound / an empty range).
    """
    m = _RANGE.match(text or "")
    if not m:
        raise ModelError("--range", f"NAME=LO:HI, e.g. {preset.coordinate}={preset.diagnose_range[0]:g}:{preset.diagnose_range[1]:g}",
                         repr(text))
    name, a, b, unit = m.groups()
    if name not in state_names:
        raise ModelError("--range", f"a state of the example ({', '.join(state_names)})", repr(name))
    if name != preset.coordinate:
        raise ModelError("--range", f"the scheduling coordinate {preset.coordinate!r} of this example", repr(name))
    try:
        lo, hi = float(a), float(b)
    except ValueError:
        raise ModelError("--range", "numbers LO:HI", f"{a!r}:{b!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ModelError("--range", "finite bounds", f"{lo}:{hi}")
    if unit == "rad" and preset.unit == "deg":
        lo, hi = math.degrees(lo), math.degrees(hi)
    elif unit == "deg" and preset.unit != "deg":
        raise ModelError("--range", f"values in {preset.unit or 'model units'} (no deg suffix)", repr(text))
    if not lo < hi:
        raise ModelError("--range", "LO < HI (a lower bound below the upper bound; a non-empty range)", f"{lo:g}:{hi:g}")
    return lo, hi


def _example_and_preset(name: str):
    from ..examples import get_example
    from .presets import get_preset

    example = get_example(name)
    if example.kind != "scalar_nonlinear":
        raise ModelError("example", "a scalar-nonlinear example of paper 004 (vehicle_tracking, magnetic_piston)",
                         f"{example.name!r} of kind {example.kind!r}")
    return example, get_preset(example.name)


def _print_json(obj) -> None:
    from ..cli import _print_json as cli_print

    cli_print(obj)


def cmd_diagnose(args: argparse.Namespace) -> int:
    """``hybobs diagnose``: verdict, certificate and report for one range."""
    from ..report.lmi_section import write_diagnosis_report
    from .diagnose import diagnose
    from .presets import scaling_for

    example, preset = _example_and_preset(args.example)
    system = example.build()
    lo, hi = parse_range(args.range, preset, system.state_names) if args.range else preset.diagnose_range
    diag = diagnose(system, preset.coordinate, preset.to_model(lo), preset.to_model(hi), unit=preset.unit,
                    factor=preset.factor, gain_bound=preset.gain_bound, min_decay=preset.min_decay,
                    overlap=preset.to_model(preset.overlap), sigma_cap=preset.sigma_cap,
                    scaling=scaling_for(preset, system))
    paths = write_diagnosis_report(diag, args.out or DEFAULT_DIAGNOSE_OUT, example.name)
    out = diag.to_dict()
    out["example"] = example.name
    out["report"] = paths
    if args.json:
        _print_json(out)
        return 0
    verdict = "FEASIBLE: a constant gain exists" if diag.feasible else "INFEASIBLE: no constant gain exists"
    print(f"{example.name}, {preset.coordinate} in [{lo:g}, {hi:g}] {preset.unit}: LMI {diag.solution.form} {verdict}")
    if diag.certificate is not None:
        c = diag.certificate
        print(f"certificate ({c.theorem}): verified in numpy = {c.verify()}; structural = {c.structural_verified}")
        print(f"  {c.reason}")
    print(f"Theorem 5 (linear subtraction): original {diag.theorem5.original_feasible}, transformed {diag.theorem5.shifted_feasible}")
    print("next:")
    for step in diag.next_steps:
        print(f"  - {step}")
    print(f"report: {paths['markdown']} and {paths['html']}")
    return 0


def cmd_synth(args: argparse.Namespace) -> int:
    """``hybobs synth``: switched gains, dwell time and hysteresis, written to ``--out``."""
    from .presets import preset_design

    example, preset = _example_and_preset(args.example)
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
    path.write_text(json.dumps(out, indent=2, default=_default))
    out["written"] = str(path)
    if args.json:
        _print_json(out)
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


def _default(value):
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def add_commands(subparsers) -> None:
    """Add ``diagnose`` and ``synth`` to the ``hybobs`` parser."""
    p = subparsers.add_parser("diagnose", help="does a constant observer gain exist? verdict, certificate, report (paper 004)")
    p.add_argument("example", help="vehicle_tracking or magnetic_piston")
    p.add_argument("--range", metavar="NAME=LO:HI", help="range of the scheduling state, e.g. psi=0:360 (deg) or z=0:203 (mm)")
    p.add_argument("--out", metavar="DIR", default=None, help=f"report directory (default {DEFAULT_DIAGNOSE_OUT})")
    p.add_argument("--json", action="store_true", help="machine-readable verdict and certificate")
    p.set_defaults(func=cmd_diagnose)

    p = subparsers.add_parser("synth", help="switched observer gains, dwell time and hysteresis (paper 004)")
    p.add_argument("example", help="vehicle_tracking or magnetic_piston")
    p.add_argument("--out", required=True, metavar="FILE", help="gains JSON file")
    p.add_argument("--range", metavar="NAME=LO:HI", help="range of the scheduling state (default: the preset's)")
    p.add_argument("--max-rate", type=float, default=None, metavar="R",
                   help="maximum rate of the scheduling state (unit/s) for the hysteresis")
    p.add_argument("--json", action="store_true", help="print the gains JSON")
    p.set_defaults(func=cmd_synth)
