"""The scenarios behind ``hybobs observe NAME``: one function per example, defined by the studies.

A scenario takes the parsed CLI options (``observer``, ``filter``, ``plot``, ``json``) and
returns a JSON-ready summary dict (the contract of each issue's "machine-readable output").
Each module of :data:`SCENARIO_MODULES` defines ``register_scenarios(register)``; they are
imported only when a scenario is asked for (they import the solvers).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from hybobs_opt.errors import ModelError

Scenario = Callable[[Any], dict[str, Any]]

_SCENARIOS: dict[str, Scenario] = {}
_LOADED: set[str] = set()

#: Study modules with observer scenarios (each defines ``register_scenarios(register)``).
SCENARIO_MODULES: list[str] = [
    "hybobs_opt.studies.paper000_driveline.scenario",
    "hybobs_opt.studies.paper001_sliding_mode.scenarios",
    "hybobs_opt.studies.paper002_powertrain.bench",
    "hybobs_opt.studies.paper003_switching.scenarios",
    "hybobs_opt.studies.paper004_nonmonotonic.scenarios",
]


def register_scenario(example: str, scenario: Scenario) -> None:
    """Register the observer scenario of ``example`` (last registration wins)."""
    _SCENARIOS[example] = scenario


def _load() -> None:
    for module in SCENARIO_MODULES:
        if module not in _LOADED:
            importlib.import_module(module).register_scenarios(register_scenario)
            _LOADED.add(module)


def get_scenario(example: str) -> Scenario:
    """The registered scenario; the error says which examples have one."""
    _load()
    try:
        return _SCENARIOS[example]
    except KeyError:
        raise ModelError(
            "hybobs observe",
            f"an example with an observer scenario (one of {sorted(_SCENARIOS) or 'none yet'})",
            repr(example),
        ) from None
