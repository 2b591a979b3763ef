"""Import paths that moved: old module and attribute names keep working.

Issue 13 separated the core toolbox from the paper studies and the application (DESIGN.md, three
tiers).  Users' scripts import today's paths (``hybobs_opt.examples.powertrain``,
``hybobs_opt.lmi.presets``, ``hybobs_opt.observers.bench`` ...), so every moved module is
registered here and served under its old name by a meta-path finder: the old name and the new one
are the *same module object* (so ``monkeypatch`` on either reaches the code).  The folders then
show where code really lives, and no core file holds an import of a study, the CLI or the report.

Names that moved out of a core module that stays (a paper scenario cut out of an observer module)
are served by that module's ``__getattr__`` through :func:`moved_attribute`, on first access only.

This module imports nothing of the package; it is installed by ``hybobs_opt/__init__.py``.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
from typing import Any

#: Old module name -> the module that now holds its code.
MOVED_MODULES: dict[str, str] = {
    "hybobs_opt.examples.registry": "hybobs_opt.studies.registry",
    "hybobs_opt.examples.driveline": "hybobs_opt.studies.paper000_driveline.systems",
    "hybobs_opt.examples.sliding_mode": "hybobs_opt.studies.paper001_sliding_mode.systems",
    "hybobs_opt.examples.powertrain": "hybobs_opt.studies.paper002_powertrain.systems",
    "hybobs_opt.examples.switching": "hybobs_opt.studies.paper003_switching.systems",
    "hybobs_opt.examples.nonmonotonic": "hybobs_opt.studies.paper004_nonmonotonic.systems",
    "hybobs_opt.examples.piston_pwa": "hybobs_opt.studies.paper004_nonmonotonic.piston_pwa",
    "hybobs_opt.lmi.presets": "hybobs_opt.studies.paper004_nonmonotonic.presets",
    "hybobs_opt.lmi.commands": "hybobs_opt.cli.diagnose",
    "hybobs_opt.observers.bench": "hybobs_opt.studies.paper002_powertrain.bench",
    "hybobs_opt.observers.piston_comparison": "hybobs_opt.studies.paper004_nonmonotonic.piston_comparison",
    "hybobs_opt.observers.scenarios": "hybobs_opt.studies.scenarios",
}

#: Old package name -> the package that replaced it.  The old package is a thin module of its
#: own (its old submodules are :data:`MOVED_MODULES` entries), whose other attributes are read
#: from the new package.
MOVED_PACKAGES: dict[str, str] = {
    "hybobs_opt.examples": "hybobs_opt.studies",
}

#: Core module -> {attribute: module that now defines it}, for names cut out of modules that stay.
MOVED_ATTRIBUTES: dict[str, dict[str, str]] = {
    "hybobs_opt.observers.hybrid_observer": {name: "hybobs_opt.studies.paper000_driveline.scenario" for name in (
        "DRIVELINE_K_LOW", "DRIVELINE_DELTA", "DRIVELINE_EPSILON", "DRIVELINE_Z0", "DRIVELINE_INVARIANT_RTOL",
        "DRIVELINE_DECAY", "DRIVELINE_GAIN_BOUND", "DRIVELINE_DWELL", "DRIVELINE_X", "DRIVELINE_U", "DRIVELINE_X0_GUESS",
        "DrivelineResult", "run_driveline", "driveline_scenario", "plot_fig6",
    )},
    "hybobs_opt.observers.sliding_mode": {name: "hybobs_opt.studies.paper001_sliding_mode.scenarios" for name in (
        "relay_oscillator", "INITIAL_ERROR_FRACTION", "ScenarioSpec", "SCENARIOS", "ScenarioResult", "simulate_truth",
        "run_scenario", "summarize", "TRADEOFF_NOISE_REL", "TRADEOFF_FILTER_STEPS", "filter_tradeoff", "_plot",
    )},
    "hybobs_opt.observers.drift_observer": {name: "hybobs_opt.studies.paper003_switching.scenarios" for name in (
        "junction_paper_gains", "OBSERVER_KINDS", "SERVER_ESTIMATE_X_BAR", "scenario_gains", "run_drift_scenario",
        "plot_drift_run",
    )},
    "hybobs_opt.observers.switched_gain": {name: "hybobs_opt.studies.paper004_nonmonotonic.scenarios" for name in (
        "VEHICLE_X_HAT0", "PISTON_POSITION_ERROR_MM", "CONVERGENCE_TOL", "cached_design", "run_example", "summarize",
    )},
}


def moved_attribute(module: str, name: str) -> Any:
    """The attribute ``name`` that moved out of ``module`` (for a module-level ``__getattr__``).

    Raises
    ------
    AttributeError
        ``name`` never lived in ``module`` (the normal message of a missing attribute).
    """
    target = MOVED_ATTRIBUTES.get(module, {}).get(name)
    if target is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    return getattr(importlib.import_module(target), name)


class _AliasLoader(importlib.abc.Loader):
    """Loads an old module name as the module object of its new home."""

    def __init__(self, target: str) -> None:
        self.target = target
        self._spec: Any = None

    def create_module(self, spec):  # noqa: D401 - importlib protocol
        module = importlib.import_module(self.target)
        self._spec = module.__spec__
        return module

    def exec_module(self, module) -> None:
        # importlib has just set ``__spec__`` to the alias's spec; the module keeps its own.
        module.__spec__ = self._spec


class _PackageAliasLoader(importlib.abc.Loader):
    """An old package: a module whose attributes are its old submodules or the new package's names."""

    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec):
        return None  # a fresh module object

    def exec_module(self, module) -> None:
        old, target = module.__name__, self.target
        new = importlib.import_module(target)
        module.__doc__ = f"Old name of :mod:`{target}` (kept for users' scripts)."
        module.__all__ = list(getattr(new, "__all__", ()))

        def __getattr__(name: str) -> Any:
            if f"{old}.{name}" in MOVED_MODULES:
                return importlib.import_module(f"{old}.{name}")
            return getattr(new, name)

        module.__getattr__ = __getattr__


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        if fullname in MOVED_PACKAGES:
            spec = importlib.machinery.ModuleSpec(fullname, _PackageAliasLoader(MOVED_PACKAGES[fullname]), is_package=True)
            spec.submodule_search_locations = []
            return spec
        new = MOVED_MODULES.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(new), is_package=False)


_FINDER = _AliasFinder()


def install() -> None:
    """Put the alias finder first on ``sys.meta_path`` (idempotent)."""
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)
