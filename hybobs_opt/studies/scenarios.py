"""The scenarios behind ``hybobs observe NAME``: one function per example, registered by the
observer modules (each paper's observer issue adds its own).

A scenario takes the parsed CLI arguments (``observer``, ``filter``, ``plot``, ``json``) and
returns a JSON-ready summary dict (the contract of each issue's "machine-readable output").
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from ..errors import ModelError

Scenario = Callable[[argparse.Namespace], dict[str, Any]]

_SCENARIOS: dict[str, Scenario] = {}

#: Modules that register scenarios on import (each calls :func:`register_scenario`).
SCENARIO_MODULES: list[str] = [
    "hybobs_opt.observers.bench",
    "hybobs_opt.observers.switched_gain",
    "hybobs_opt.observers.hybrid_observer",
    "hybobs_opt.observers.drift_observer",
    "hybobs_opt.observers.sliding_mode",
]


def register_scenario(example: str, scenario: Scenario) -> None:
    """Register the observer scenario of ``example`` (last registration wins)."""
    _SCENARIOS[example] = scenario


def get_scenario(example: str) -> Scenario:
    """The registered scenario; the error says which examples have one."""
    import importlib

    for module in SCENARIO_MODULES:
        importlib.import_module(module)
    try:
        return _SCENARIOS[example]
    except KeyError:
        raise ModelError(
            "hybobs observe",
            f"an example with an observer scenario (one of {sorted(_SCENARIOS) or 'none yet'})",
            repr(example),
        ) from None
