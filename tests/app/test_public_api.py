"""One obvious import, one path per name, one reset keyword."""

from __future__ import annotations

import importlib
import inspect

import numpy as np
import pytest

import hybobs_opt
from hybobs_opt.errors import ModelError


def test_main_objects_import_from_the_package():
    from hybobs_opt import LookupObserver, MHEObserver, PWASystem, analyse_observability
    from hybobs_opt.mhe.observer import MHEObserver as mhe_old
    from hybobs_opt.observers.lookup import LookupObserver as lookup_old
    from hybobs_opt.regions.observability import analyse_observability as analyse_old
    from hybobs_opt.systems.pwa import PWASystem as pwa_old

    assert (LookupObserver, MHEObserver, PWASystem, analyse_observability) == (lookup_old, mhe_old, pwa_old, analyse_old)


@pytest.mark.parametrize("package", ["hybobs_opt", "hybobs_opt.observers", "hybobs_opt.systems", "hybobs_opt.regions",
                                     "hybobs_opt.synthesis", "hybobs_opt.lmi", "hybobs_opt.mhe", "hybobs_opt.sim",
                                     "hybobs_opt.studies"])
def test_every_exported_name_resolves(package):
    mod = importlib.import_module(package)
    missing = [name for name in mod.__all__ if getattr(mod, name, None) is None and name != "__version__"]
    assert missing == []


def test_every_observer_family_is_exported():
    from hybobs_opt import (ContinuousObserver, DriftObserver, HybridObserver, LocationObserver, LookupObserver,
                            MHEObserver, Observer, PeriodicObserver, SlidingModeObserver, SwitchedGainObserver)

    for cls in (ContinuousObserver, DriftObserver, HybridObserver, LocationObserver, LookupObserver, MHEObserver,
                PeriodicObserver, SlidingModeObserver, SwitchedGainObserver):
        assert issubclass(cls, Observer), cls


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'NoSuchObserver'"):
        hybobs_opt.NoSuchObserver  # noqa: B018
    with pytest.raises(ImportError):
        from hybobs_opt.observers import NoSuchObserver  # noqa: F401


#: Old import paths that served moved code until the compatibility layer was removed: they are gone.
OLD_PATHS = ("hybobs_opt._" + "compat",  # spelt in two parts: the repository holds no reference to it
             "hybobs_opt.examples", "hybobs_opt.examples.powertrain", "hybobs_opt.lmi.presets",
             "hybobs_opt.lmi.commands", "hybobs_opt.observers.bench", "hybobs_opt.observers.piston_comparison",
             "hybobs_opt.observers.scenarios", "hybobs_opt.lp", "hybobs_opt._lp_kernels", "hybobs_opt.systems._validate",
             "hybobs_opt.systems.polytope", "hybobs_opt.observers.base", "hybobs_opt.mhe.miqp")


@pytest.mark.parametrize("old", OLD_PATHS)
def test_an_old_import_path_is_gone(old):
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)


#: Documented names of papers 000-003 and of the MHE arrival weight that moved to ``hybobs_opt.synthesis``.
MOVED_TO_SYNTHESIS = {
    "hybobs_opt.observers": ("ContinuousDesign", "ConvergenceBound", "GainRule", "PeriodicGains", "ResidualBank",
                             "convergence_bound", "deadbeat_gains", "design_continuous_observer", "design_gains",
                             "design_residual_bank", "discretization_band", "positive_deadbeat_gains",
                             "positive_gain_bounds", "positive_observer"),
    "hybobs_opt.mhe": ("ArrivalPrior", "certified_arrival_prior"),
}


@pytest.mark.parametrize("package,name", [(p, n) for p, names in MOVED_TO_SYNTHESIS.items() for n in names])
def test_a_moved_design_warns_once_and_is_the_synthesis_object(package, name):
    import hybobs_opt.synthesis as synthesis

    mod = importlib.import_module(package)
    assert name not in mod.__all__ and name not in dir(mod)
    with pytest.warns(FutureWarning, match=rf"{package}\.{name} is deprecated .* 0\.2\.0: use hybobs_opt\.synthesis\.{name}"):
        value = getattr(mod, name)
    assert value is getattr(synthesis, name)
    with pytest.warns(FutureWarning):  # never cached: every access warns
        getattr(mod, name)


def _defined_names(path) -> set[str]:
    """Names bound at the top level of a module (definitions and assignments, not imports)."""
    import ast

    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                names.update(x.id for x in ast.walk(target) if isinstance(x, ast.Name))
    return names


def imports_through_a_second_path(root) -> list[str]:
    """``file:line: module.name`` of each ``from hybobs_opt.<module> import name`` in the package, the tests,
    benchmarks and scripts where ``<module>`` is a plain module (not a package face) that does not define
    ``name`` itself but imported it from elsewhere."""
    import ast

    bad = []
    for folder in ("hybobs_opt", "tests", "benchmarks", "scripts"):
        for path in sorted((root / folder).rglob("*.py")):
            rel = path.relative_to(root).with_suffix("").parts
            package = rel[:-1]
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if not isinstance(node, ast.ImportFrom):
                    continue
                parts = (list(package[: len(package) - node.level + 1]) if node.level else []) + (node.module or "").split(".")
                parts = [x for x in parts if x]
                if not parts or parts[0] != "hybobs_opt":
                    continue
                target = root.joinpath(*parts)
                if not target.with_suffix(".py").is_file():
                    continue  # a package face re-exports by design
                defined = _defined_names(target.with_suffix(".py"))
                for alias in node.names:
                    sub = target / alias.name
                    if alias.name != "*" and alias.name not in defined and not sub.with_suffix(".py").is_file() \
                            and not (sub / "__init__.py").is_file():
                        bad.append(f"{path.relative_to(root)}:{node.lineno}: {'.'.join(parts)}.{alias.name}")
    return bad


def test_every_import_names_the_module_that_defines_the_name():
    """One path per name: a module imports a name from where it is defined (or from a package face)."""
    from pathlib import Path

    assert imports_through_a_second_path(Path(__file__).resolve().parents[2]) == []


def test_the_second_path_finder_finds_one(tmp_path):
    (tmp_path / "hybobs_opt" / "observers").mkdir(parents=True)
    (tmp_path / "hybobs_opt" / "observers" / "__init__.py").write_text("")
    (tmp_path / "hybobs_opt" / "observers" / "a.py").write_text("from .b import thing\nOWN = 1\n")
    (tmp_path / "hybobs_opt" / "observers" / "b.py").write_text("thing = 2\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "t.py").write_text("from hybobs_opt.observers.a import OWN, thing\n"
                                             "from hybobs_opt.observers import a\nfrom hybobs_opt.observers.b import thing\n")
    assert imports_through_a_second_path(tmp_path) == ["tests/t.py:1: hybobs_opt.observers.a.thing"]


@pytest.mark.parametrize("core,name", [("hybobs_opt.observers.hybrid_observer", "run_driveline"),
                                       ("hybobs_opt.observers.sliding_mode", "SCENARIOS"),
                                       ("hybobs_opt.observers.drift_observer", "run_drift_scenario"),
                                       ("hybobs_opt.observers.switched_gain", "run_example")])
def test_a_core_module_serves_no_study_name(core, name):
    with pytest.raises(AttributeError):
        getattr(importlib.import_module(core), name)


def test_catalogue_metadata_matches_the_factories():
    """The catalogue is written without importing the factories: check it against them."""
    from hybobs_opt.studies import list_examples

    for ex in list_examples():
        system = ex.build()
        names = tuple(getattr(system, "state_names"))
        assert names == ex.state_names, ex.name
        fn = ex.build.resolve()
        sig = inspect.signature(fn)
        defaults = {k: p.default for k, p in sig.parameters.items() if p.default is not inspect.Parameter.empty}
        for key, value in ex.params.items():
            if key in defaults:
                assert np.allclose(np.asarray(defaults[key], dtype=float), np.asarray(value, dtype=float)), (ex.name, key)
    from hybobs_opt.studies.paper000_driveline.systems import TABLE1, DEFAULT_T_FINAL
    from hybobs_opt.studies.paper002_powertrain.systems import TABLE1 as PT1, TABLE2 as PT2
    from hybobs_opt.studies import get_example

    assert get_example("driveline").params == TABLE1 and get_example("driveline").default_t_final == DEFAULT_T_FINAL
    assert get_example("powertrain3").params["gear_ratio"] == PT1["gear_ratio"]
    assert get_example("powertrain5").params["gear_ratio"] == PT2["gear_ratio"]


def test_lazy_factory_reference_errors_name_the_field():
    from hybobs_opt.studies.registry import Example, LazyCallable

    with pytest.raises(ModelError, match="module:function"):
        LazyCallable("no_colon_here")
    with pytest.raises(ModelError, match="Example.build"):
        Example("x", "pwa", "002", "", ("a",), 3.0, "m:f", 1.0)


def test_saved_regions_name_their_system_through_the_resolver():
    from hybobs_opt.systems.resolve import resolve_system

    assert resolve_system("powertrain3").state_names == ("theta", "omega_m", "omega_l")
    assert resolve_system("hybobs_opt.studies.paper002_powertrain.systems:powertrain3", {"gear_ratio": 0.1}).n == 3
    with pytest.raises(ModelError, match="system name"):
        resolve_system("no_such_example")


# ------------------------------------------------------------------ one keyword for the initial mode
def test_reset_takes_q0_everywhere_and_the_old_keywords_agree():
    from hybobs_opt import DriftObserver, PeriodicObserver, deadbeat_gains, periodic_system
    from hybobs_opt.studies.paper003_switching.systems import switching_server

    system = switching_server()
    new, old = DriftObserver(system), DriftObserver(system)
    new.reset([0.0, 3.0, 1.0], t0=0.0, q0=2)
    with pytest.warns(FutureWarning, match=r"reset\(mode=\.\.\.\) is deprecated .* 0\.2\.0: use reset\(q0=\.\.\.\)"):
        old.reset([0.0, 3.0, 1.0], t0=0.0, mode=2)
    assert new.step([0.5], [0.0]).mode == old.step([0.5], [0.0]).mode == 2
    with pytest.raises(ModelError, match="q0"), pytest.warns(FutureWarning):
        new.reset([0.0, 3.0, 1.0], q0=2, mode=4)
    ps = periodic_system(system)
    po, po_old = PeriodicObserver(ps, deadbeat_gains(ps)), PeriodicObserver(ps, deadbeat_gains(ps))
    v = ps.event_modes[-1]
    po.reset([1.0, 2.0], t0=0.0, q0=v)
    with pytest.warns(FutureWarning, match="mode"):
        po_old.reset([1.0, 2.0], t0=0.0, mode=v)
    assert po.step([3.0], [ps.event_modes[0]]).mode == po_old.step([3.0], [ps.event_modes[0]]).mode
    for cls in (DriftObserver, PeriodicObserver):
        assert "q0" in inspect.signature(cls.reset).parameters


def test_every_observer_reset_names_q0_when_it_takes_an_initial_mode():
    from hybobs_opt import (ContinuousObserver, DriftObserver, HybridObserver, LocationObserver, MHEObserver,
                            PeriodicObserver, SwitchedGainObserver)

    for cls in (ContinuousObserver, DriftObserver, HybridObserver, LocationObserver, MHEObserver, PeriodicObserver,
                SwitchedGainObserver):
        assert "q0" in inspect.signature(cls.reset).parameters, cls.__name__


def test_every_study_names_its_scenario_runner_run_scenario():
    for module in ("paper000_driveline.scenario", "paper001_sliding_mode.scenarios", "paper002_powertrain.bench",
                   "paper003_switching.scenarios", "paper004_nonmonotonic.scenarios"):
        assert callable(importlib.import_module(f"hybobs_opt.studies.{module}").run_scenario), module
    from hybobs_opt.studies.paper000_driveline.scenario import run_scenario

    with pytest.raises(ModelError, match="driveline"):
        run_scenario("powertrain3")
