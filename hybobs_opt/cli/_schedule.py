"""What ``hybobs diagnose`` and ``hybobs synth`` share: the paper 004 example and its preset, and
the ``--range NAME=LO:HI[deg|rad]`` option in the preset's display units."""

from __future__ import annotations

import math
import re

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


def example_and_preset(name: str):
    from ..studies import get_example
    from ..studies.paper004_nonmonotonic.presets import get_preset

    example = get_example(name)
    if example.kind != "scalar_nonlinear":
        raise ModelError("example", "a scalar-nonlinear example of paper 004 (vehicle_tracking, magnetic_piston)",
                         f"{example.name!r} of kind {example.kind!r}")
    return example, get_preset(example.name)
