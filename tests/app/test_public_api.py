"""One obvious import, old paths kept, one reset keyword (issue 13)."""

from __future__ import annotations

import importlib
import inspect

import numpy as np
import pytest

import hybobs_opt
from hybobs_opt import _compat
from hybobs_opt.errors import ModelError


def test_main_objects_import_from_the_package():
    from hybobs_opt import LookupObserver, MHEObserver, PWASystem, analyse_observability
    from hybobs_opt.mhe.observer import MHEObserver as mhe_old
    from hybobs_opt.observers.lookup import LookupObserver as lookup_old
    from hybobs_opt.regions.observability import analyse_observability as analyse_old
    from hybobs_opt.systems.pwa import PWASystem as pwa_old

    assert (LookupObserver, MHEObserver, PWASystem, analyse_observability) == (lookup_old, mhe_old, pwa_old, analyse_old)


@pytest.mark.parametrize("package", ["hybobs_opt", "hybobs_opt.observers", "hybobs_opt.systems", "hybobs_opt.regions",
                                     "hybobs_opt.lmi", "hybobs_opt.mhe", "hybobs_opt.sim", "hybobs_opt.studies"])
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


@pytest.mark.parametrize("old,new", sorted(_compat.MOVED_MODULES.items()))
def test_moved_module_is_the_same_object_under_its_old_name(old, new):
    assert importlib.import_module(old) is importlib.import_module(new)
    assert importlib.import_module(old).__spec__.name == new  # the module keeps its own spec


def test_old_package_examples_still_lists_and_imports():
    from hybobs_opt.examples import get_example, list_examples, powertrain
    from hybobs_opt.studies.paper002_powertrain import systems

    assert powertrain is systems
    assert [e.name for e in list_examples()][:2] == ["driveline", "switched_unstable"]
    assert get_example("powertrain3").state_names == ("theta", "omega_m", "omega_l")


@pytest.mark.parametrize("core", sorted(_compat.MOVED_ATTRIBUTES))
def test_moved_attributes_resolve_from_the_core_module(core):
    mod = importlib.import_module(core)
    for name, target in _compat.MOVED_ATTRIBUTES[core].items():
        assert getattr(mod, name) is getattr(importlib.import_module(target), name), (core, name)
    with pytest.raises(AttributeError):
        getattr(mod, "no_such_name")


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
    old.reset([0.0, 3.0, 1.0], t0=0.0, mode=2)
    assert new.step([0.5], [0.0]).mode == old.step([0.5], [0.0]).mode == 2
    with pytest.raises(ModelError, match="q0"):
        new.reset([0.0, 3.0, 1.0], q0=2, mode=4)
    ps = periodic_system(system)
    po, po_old = PeriodicObserver(ps, deadbeat_gains(ps)), PeriodicObserver(ps, deadbeat_gains(ps))
    v = ps.event_modes[-1]
    po.reset([1.0, 2.0], t0=0.0, q0=v)
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
