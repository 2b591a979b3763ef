"""What ``hybobs diagnose`` and ``hybobs synth`` share: the system, its design settings (the paper
004 examples' published presets, or settings read from the model for any other scalar-nonlinear
system) and the ``--range NAME=LO:HI`` option."""

from __future__ import annotations

import argparse
import math
import re

from ..errors import ModelError

DEFAULT_DIAGNOSE_OUT = "out/diagnose"

_RANGE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:]+):([^:]+?)\s*(deg|rad)?\s*$")


#: Options of a design from the model -> the parameter of :func:`hybobs_opt.lmi.auto_design.design_settings`
#: they are passed as (core errors name the parameter; the CLI names the option).
DESIGN_OPTIONS = {"gain_bound": "--gain-bound", "min_decay": "--min-decay", "overlap": "--overlap",
                  "max_rate": "--max-rate", "range": "--range", "coordinate": "--coordinate",
                  "scheduling coordinate": "--coordinate", "condition": "--condition"}


def check_range_in_box(system, name: str, lo: float, hi: float, unit: str = "", factor: float = 1.0) -> None:
    """``ModelError("--range")`` unless ``[lo, hi]`` (display units: model units / ``factor``) lies in the
    system's operating box of the state ``name`` (outside it a grown region is empty; checked before any LMI)."""
    from ..tolerances import MEMBERSHIP_RTOL

    k = list(system.state_names).index(name)
    blo, bhi = float(system.box_lower[k]) / factor, float(system.box_upper[k]) / factor
    if lo < blo - MEMBERSHIP_RTOL * (1 + abs(blo)) or hi > bhi + MEMBERSHIP_RTOL * (1 + abs(bhi)):
        show = f"[{blo:g}, {bhi:g}]" + (f" {unit}" if unit else "")
        raise ModelError("--range", f"a range inside the operating range of {name}, {show} (beyond it a region of the "
                         "design would be an empty region)", f"{lo:g}:{hi:g}")


def parse_range(text: str, preset, state_names: tuple[str, ...], system=None) -> tuple[float, float]:
    """``NAME=LO:HI[deg|rad]`` -> ``(lo, hi)`` in the preset's display units.

    Raises
    ------
    ModelError
        Malformed text, a coordinate other than the preset's scheduling state, non-numbers,
        non-finite values, or ``LO >= HI`` (lower bound above upper bound / an empty range);
        with ``system``, a range beyond its operating box.
    """
    name, lo, hi, unit = _split_range(text, state_names, f"{preset.coordinate}={preset.diagnose_range[0]:g}:{preset.diagnose_range[1]:g}",
                                      "example")
    if name != preset.coordinate:
        raise ModelError("--range", f"the scheduling coordinate {preset.coordinate!r} of this example", repr(name))
    if unit == "rad" and preset.unit == "deg":
        lo, hi = math.degrees(lo), math.degrees(hi)
    elif unit == "deg" and preset.unit != "deg":
        raise ModelError("--range", f"values in {preset.unit or 'model units'} (no deg suffix)", repr(text))
    if not lo < hi:
        raise ModelError("--range", "LO < HI (a lower bound below the upper bound; a non-empty range)", f"{lo:g}:{hi:g}")
    if system is not None:
        check_range_in_box(system, name, lo, hi, preset.unit, preset.factor)
    return lo, hi


def _split_range(text: str, state_names: tuple[str, ...], example: str, what: str = "system") -> tuple[str, float, float, str | None]:
    m = _RANGE.match(text or "")
    if not m:
        raise ModelError("--range", f"NAME=LO:HI, e.g. {example}", repr(text))
    name, a, b, unit = m.groups()
    if name not in state_names:
        raise ModelError("--range", f"a state of the {what} ({', '.join(state_names)})", repr(name))
    try:
        lo, hi = float(a), float(b)
    except ValueError:
        raise ModelError("--range", "numbers LO:HI", f"{a!r}:{b!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ModelError("--range", "finite bounds", f"{lo}:{hi}")
    return name, lo, hi, unit


def add_design_arguments(p: argparse.ArgumentParser) -> None:
    """The options of a design from the model (any scalar-nonlinear system)."""
    p.add_argument("--range", metavar="NAME=LO:HI", help="range of the scheduling state (examples: in the preset's "
                   "unit, e.g. psi=0:360 (deg) or z=0:203 (mm); other systems: model units)")
    p.add_argument("--coordinate", metavar="STATE", help="scheduling state (default: where the non-monotonic functions act)")
    p.add_argument("--gain-bound", type=float, default=None, metavar="X", help="bound on ||L||_2 (default: from the model, see 'settings')")
    p.add_argument("--min-decay", type=float, default=None, metavar="RATE", help="decay rate every grown region must admit (1/s)")
    p.add_argument("--overlap", type=float, default=None, metavar="X", help="hysteresis epsilon of the regions (model units)")
    p.add_argument("--condition", choices=("paper", "per_function", "polytopic"), default=None,
                   help="region condition of the design (default with model settings: polytopic, the least "
                        "conservative; the paper's settings use the paper's LMI)")
    p.add_argument("--settings", choices=("paper", "model"), default=None,
                   help="paper: an example's published settings (default for vehicle_tracking, magnetic_piston); "
                        "model: settings read from the model (default for every other system)")


def design_setup(args: argparse.Namespace):
    """``(named, preset, settings)``: the preset path (``settings`` None) for a paper example, the model path otherwise."""
    from ..lmi.auto_design import design_settings
    from ..studies.paper004_nonmonotonic.presets import PRESETS
    from ._common import as_options, load_system, require_kind

    named = load_system(args)
    require_kind(named, ("scalar_nonlinear",), "the observer LMIs of paper 004")
    has_preset = named.example is not None and named.example.name in PRESETS
    mode = args.settings or ("paper" if has_preset else "model")
    if mode == "paper":
        if not has_preset:
            raise ModelError("--settings", f"'model' for {named.label!r} (only {sorted(PRESETS)} have published settings)", "'paper'")
        given = [f"--{o.replace('_', '-')}" for o in ("coordinate", "gain_bound", "min_decay", "overlap", "condition")
                 if getattr(args, o, None) is not None]
        if given:
            raise ModelError(given[0], "no value with the paper's settings (add --settings model to choose your own)", "a value")
        return named, PRESETS[named.example.name], None
    lo = hi = None
    coordinate = args.coordinate
    if args.range:
        name, lo, hi, unit = _split_range(args.range, named.system.state_names, f"{named.system.state_names[0]}=LO:HI")
        if unit is not None:
            raise ModelError("--range", "values in model units (no deg/rad suffix: a model file has one unit per state)", repr(args.range))
        if not lo < hi:
            raise ModelError("--range", "LO < HI (a non-empty range)", f"{lo:g}:{hi:g}")
        if coordinate is not None and coordinate != name:
            raise ModelError("--range", f"the coordinate given by --coordinate ({coordinate})", repr(name))
        check_range_in_box(named.system, name, lo, hi)
        coordinate = name
    if coordinate is not None and coordinate not in named.system.state_names:
        raise ModelError("--coordinate", f"a state of the system ({', '.join(named.system.state_names)})", repr(coordinate))
    from ..limits import MAX_GAIN_BOUND

    if args.gain_bound is not None and args.gain_bound > MAX_GAIN_BOUND:
        raise ModelError("--gain-bound", f"at most {MAX_GAIN_BOUND:g} (hybobs_opt.limits.MAX_GAIN_BOUND: the LMIs take "
                         "the bound squared)", repr(args.gain_bound))
    rate = getattr(args, "max_rate", None)
    with as_options(DESIGN_OPTIONS):
        settings = design_settings(named.system, coordinate, lo, hi, gain_bound=args.gain_bound, min_decay=args.min_decay,
                                   overlap=args.overlap, rate=rate, condition=getattr(args, "condition", None))
    if args.min_decay is not None and settings.min_decay > settings.sigma_cap:
        raise ModelError("--min-decay", f"at most the largest decay rate the design searches, sigma_cap = "
                         f"{settings.sigma_cap:g} 1/s", repr(args.min_decay))
    if args.overlap is not None and not settings.overlap < settings.hi - settings.lo:
        raise ModelError("--overlap", f"a hysteresis smaller than the range of {settings.coordinate}, "
                         f"{settings.hi - settings.lo:g} (model units)", repr(args.overlap))
    return named, None, settings
