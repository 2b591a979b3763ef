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


#: Old import paths that served moved code until the compatibility layer was removed: they are gone.
OLD_PATHS = ("hybobs_opt._compat", "hybobs_opt.examples", "hybobs_opt.examples.powertrain", "hybobs_opt.lmi.presets",
             "hybobs_opt.lmi.commands", "hybobs_opt.observers.bench", "hybobs_opt.observers.piston_comparison",
             "hybobs_opt.observers.scenarios", "hybobs_opt.lp", "hybobs_opt._lp_kernels", "hybobs_opt.systems._validate",
             "hybobs_opt.systems.polytope", "hybobs_opt.observers.base", "hybobs_opt.mhe.miqp")


@pytest.mark.parametrize("old", OLD_PATHS)
def test_an_old_import_path_is_gone(old):
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)


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
