"""``hybobs diagnose EXAMPLE [--range psi=0:360] [--out DIR] [--json]``: is there a constant
observer gain on the range (paper 004, LMI (8))?

Writes a Markdown and an HTML report (verdict, certificate, Jacobian-bound plots, what to do
next) into ``DIR`` and prints the verdict; ``--json`` prints ``feasible`` and, when infeasible,
``certificate`` with ``verified``, ``reason`` and ``theorem``.  Ranges are in the preset's
display unit of the coordinate (degrees for ``psi``, mm for ``z``); ``psi=0:6.28rad`` gives
radians explicitly.  (This module is also the old ``hybobs_opt.lmi.commands``.)
"""

from __future__ import annotations

import argparse
import math
import re

from ..errors import ModelError
from ._common import print_json

HELP = "does a constant observer gain exist? verdict, certificate, report (paper 004)"

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


def example_and_preset(name: str):
    from ..studies import get_example
    from ..studies.paper004_nonmonotonic.presets import get_preset

    example = get_example(name)
    if example.kind != "scalar_nonlinear":
        raise ModelError("example", "a scalar-nonlinear example of paper 004 (vehicle_tracking, magnetic_piston)",
                         f"{example.name!r} of kind {example.kind!r}")
    return example, get_preset(example.name)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("example", help="vehicle_tracking or magnetic_piston")
    p.add_argument("--range", metavar="NAME=LO:HI", help="range of the scheduling state, e.g. psi=0:360 (deg) or z=0:203 (mm)")
    p.add_argument("--out", metavar="DIR", default=None, help=f"report directory (default {DEFAULT_DIAGNOSE_OUT})")
    p.add_argument("--json", action="store_true", help="machine-readable verdict and certificate")


def cmd_diagnose(args: argparse.Namespace) -> int:
    """``hybobs diagnose``: verdict, certificate and report for one range."""
    from ..lmi.diagnose import diagnose
    from ..report.lmi_section import write_diagnosis_report
    from ..studies.paper004_nonmonotonic.presets import scaling_for

    example, preset = example_and_preset(args.example)
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
        print_json(out)
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


run = cmd_diagnose


def cmd_synth(args: argparse.Namespace) -> int:
    """``hybobs synth`` (see :mod:`.synth`)."""
    from .synth import run as synth_run

    return synth_run(args)


def add_commands(subparsers) -> None:
    """Add ``diagnose`` and ``synth`` to a ``hybobs`` subparsers object (the old registration hook)."""
    from . import synth

    p = subparsers.add_parser("diagnose", help=HELP)
    add_arguments(p)
    p.set_defaults(func=cmd_diagnose)
    p = subparsers.add_parser("synth", help=synth.HELP)
    synth.add_arguments(p)
    p.set_defaults(func=synth.run)


#: Old private name (``hybobs_opt.lmi.commands._example_and_preset``).
_example_and_preset = example_and_preset
