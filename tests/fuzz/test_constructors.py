"""Fuzz family 1: constructor inputs (issue 16).

Valid inputs are taken from the shipped examples (``hybobs_opt.studies.get_example``) and their
study scenarios (:mod:`.scenarios`); hypothesis picks one field or argument and one garbage value
for it from the tables of :mod:`.strategies` (wrong types, complex, NaN/inf, empty and
wrong-shape arrays, names that are an int, ``None``, ``''``, duplicated or a plain string,
callables of the wrong length or returning NaN/None, out-of-range integers, non-positive
periods).  Every one must be refused with a :class:`~hybobs_opt.errors.ModelError`:

* the system classes of the ten examples (``PWASystem``/``PWAMode``, ``HybridAutomaton``/
  ``Location``/``Edge``, ``ScalarNonlinearSystem``/``ScalarFunction``, ``ConstantDriftSystem``),
  rebuilt from their own fields with one field (or one field of one mode, location, edge or
  function) replaced;
* ``Polytope(A, b, names)`` and ``Polytope.from_box(lower, upper, names)``;
* the nine observers' constructors, and their ``reset`` (``x0='abc'``, a complex or boolean
  ``x0``, wrong lengths, NaN, bad ``q0`` / ``t0``), and the moving-horizon observer's
  ``MHESettings``.

Outcomes: ``ModelError``, ``accepted-garbage`` (the constructor returned), ``other-exception:<type>``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings

import numpy as np
import pytest
from hypothesis import strategies as st

from . import scenarios as SC
from . import strategies as S
from .common import ACCEPTED_GARBAGE, Family, Target, assert_no_bugs, describe, exception_outcome, run_target, strict_warnings

EXAMPLES = ("powertrain3", "powertrain5", "driveline", "switched_unstable", "triangular", "double_scroll",
            "switching_server", "traffic_junction", "vehicle_tracking", "magnetic_piston")


def attempt(build) -> tuple[str, str]:
    """Outcome of ``build()`` on a garbage input: a refusal, an acceptance or another exception."""
    try:
        with strict_warnings():
            build()
    except Exception as exc:
        return exception_outcome(exc), f"{type(exc).__name__}: {str(exc)[:200]}"
    return ACCEPTED_GARBAGE, "accepted"


def pick(items, where: float):
    return items[min(int(where * len(items)), len(items) - 1)]


# ---------------------------------------------------------------------------------- system classes

@functools.cache
def example_system(name: str):
    from hybobs_opt.studies import get_example

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return get_example(name).build()


def init_fields(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj) if f.init}


def rebuild(obj, **changes):
    kw = init_fields(obj)
    kw.update(changes)
    return type(obj)(**kw)


def garbage_for(field: str, value, n_locations: int = 0) -> list[tuple[str, object]]:
    """The garbage table of a field from its valid value (and the object holding it)."""
    from hybobs_opt.systems import Polytope

    if isinstance(value, bool):
        return S.JUNK
    if isinstance(value, np.ndarray) and value.dtype.kind in "biuf":
        return S.array_garbage(value)
    if isinstance(value, Polytope):
        d = value.dim
        out = [("int", 5), ("str", "box"), ("matrix", np.eye(d)), ("dict", {"A": [], "b": []}),
               ("wrong-dim", Polytope.from_box([-1.0] * (d + 7), [1.0] * (d + 7)))]  # d + 1 may be n + m: valid
        if field in ("state_bounds", "invariant", "box", "input_bounds"):
            out += [("unbounded", Polytope.whole_space(d)), ("empty-set", Polytope.empty(d))]
        return out
    if field.endswith("names") and isinstance(value, tuple):
        return S.names_garbage(len(value)) if value else [("int", 3), ("bytes-entries", [b"x"]), ("plain-string", "ab")]
    if isinstance(value, str):
        out = S.text_garbage()
        if field == "partition":
            out.append(("unknown", "nosuch"))
        return out
    if isinstance(value, (int, np.integer)):
        return S.int_garbage(0, n_locations - 1 if field in ("source", "target") else None)
    if isinstance(value, float):
        return S.real_garbage(positive=True)
    if callable(value):
        return S.callable_garbage(3)
    if isinstance(value, tuple):
        one = value[0] if value else None
        out = [("int", 5), ("str", "item"), ("item-int", (5,)), ("dict", {"k": one})]
        if field != "edges":  # edges=None: every transition of the invariants
            out.append(("None", None))
        if one is not None and field in ("modes", "locations"):
            out += [("empty", ()), ("single-not-in-tuple", one)]
        return out
    return S.JUNK


def system_sites(name: str) -> list[tuple[str, object]]:
    """``(path, build(garbage) -> system)`` for every field of the example and of its parts."""
    sysm = example_system(name)
    sites = []
    for field, value in init_fields(sysm).items():
        sites.append((field, value, sysm, (lambda g, f=field: rebuild(sysm, **{f: g}))))
        if isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
            for i in sorted({0, len(value) - 1}):
                part = value[i]
                for sub, sub_value in init_fields(part).items():
                    def build(g, f=field, i=i, part=part, sub=sub):
                        items = list(getattr(sysm, f))
                        items[i] = rebuild(part, **{sub: g})
                        return rebuild(sysm, **{f: tuple(items)})

                    sites.append((f"{field}[{i}].{sub}", sub_value, part, build))
    return sites


def try_system(value) -> tuple[str, str]:
    name, where, which = value
    sites = system_sites(name)
    path, valid, owner, build = pick(sites, where)
    if valid is None:
        table = S.JUNK
    else:
        table = garbage_for(path.rsplit(".", 1)[-1].split("[")[0], valid, getattr(example_system(name), "n_locations", 0))
    label, garbage = table[which % len(table)]
    outcome, detail = attempt(lambda: build(garbage))
    return outcome, f"{name}.{path} = {label} {describe(garbage, 60)}: {detail}"


# ---------------------------------------------------------------------------------- polytopes

def try_polytope(value) -> tuple[str, str]:
    from hybobs_opt.systems import Polytope

    ctor, arg, which = value
    lo, hi = np.array([-1.0, -2.0, 0.0]), np.array([1.0, 2.0, 3.0])
    box = Polytope.from_box(lo, hi)
    if ctor == "init":
        valid = {"A": box.A, "b": box.b, "names": ("a", "b", "c")}
        table = {"A": S.array_garbage(box.A), "b": S.array_garbage(box.b), "names": S.names_garbage(3)}[arg]
        label, g = table[which % len(table)]
        outcome, detail = attempt(lambda: Polytope(**{**valid, arg: g}))
    else:
        valid = {"lower": lo, "upper": hi, "names": ("a", "b", "c")}
        table = {"lower": S.array_garbage(lo) + [("above-upper", hi + 1.0)], "upper": S.array_garbage(hi),
                 "names": S.names_garbage(3)}[arg]
        label, g = table[which % len(table)]
        outcome, detail = attempt(lambda: Polytope.from_box(**{**valid, arg: g}))
    return outcome, f"Polytope.{ctor}({arg} = {label} {describe(g, 60)}): {detail}"


# ---------------------------------------------------------------------------------- observers

def _driveline():
    res, x0 = SC.driveline_data()
    return res, float(res.trace.t[1] - res.trace.t[0]), x0


def _powertrain():
    plant, _, _, an = SC.powertrain_data()
    return plant, an


def _sliding():
    return SC.sliding_data("double_scroll")


def _switched():
    design, trace, x0 = SC.switched_data("magnetic_piston")
    return design, float(trace.t[1] - trace.t[0]), x0


def _drift():
    return SC.drift_data("switching_server")


def _periodic():
    system, ps, t, v, x = SC.periodic_data()
    from hybobs_opt.synthesis.periodic_gains import deadbeat_gains

    return system, ps, deadbeat_gains(ps)


def real_table(optional: bool = False):
    return S.real_garbage(positive=True)


def state_table(n: int):
    good = np.zeros(n)
    return [("abc", "abc"), ("complex", good + 1j), ("complex-zero-imag", good.astype(complex)),
            ("bool", np.ones(n, dtype=bool)), ("short", good[:-1]), ("long", np.zeros(n + 1)), ("nan", np.full(n, np.nan)),
            ("inf", np.full(n, np.inf)), ("none-entries", [None] * n), ("dict", {"x": 0.0}), ("nested", [good.tolist()]),
            ("str-entries", ["0"] * n), ("bytes", b"0" * n)]


def observer_specs() -> dict[str, tuple]:
    """kind -> (constructor, valid kwargs (lazy), {argument: garbage table}, {reset kwarg: garbage table})."""
    from hybobs_opt.mhe import MHESettings
    from hybobs_opt.mhe.observer import MHEObserver
    from hybobs_opt.observers.drift_observer import DriftObserver
    from hybobs_opt.observers.hybrid_observer import ContinuousObserver, HybridObserver
    from hybobs_opt.observers.location_observer import LocationObserver
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.observers.periodic import PeriodicObserver
    from hybobs_opt.observers.sliding_mode import SlidingModeObserver
    from hybobs_opt.observers.switched_gain import SwitchedGainObserver

    def bad_objects(*extra):
        return [("None", None), ("int", 5), ("str", "x"), ("object", object())] + list(extra)

    def loc(nloc):
        return S.int_garbage(0, nloc - 1)

    specs = {
        "LookupObserver": (
            LookupObserver, lambda: {"analysis": _powertrain()[1]},
            {"analysis": bad_objects(("a-system", _powertrain()[0])), "variant": [("unknown", "nosuch"), ("int", 5), ("None", None)],
             "output_rtol": real_table(), "b_tilde": [("unknown-str", "nosuch"), ("int", 5), ("list-of-int", [5])],
             "progress": [("int", 5), ("str", "x")]},
            {"x0": state_table(3)}),
        "MHEObserver": (
            MHEObserver, lambda: {"system": _powertrain()[0], "T": 3, "analysis": _powertrain()[1]},
            {"system": bad_objects(("an-analysis", _powertrain()[1])), "T": S.int_garbage(1) + [("huge", 10**9)],
             "norm": [("unknown", "3"), ("word", "two"), ("float", 5.5), ("None", None)],
             "solver": [("unknown", "nosuch"), ("int", 5)],
             "output_weight": [("nan", np.array([[np.nan]])), ("negative", np.array([[-1.0]])), ("str", "x"), ("shape", np.eye(3))],
             "x0": state_table(3), "analysis": [("int", 5), ("str", "x")],
             "settings": [("int", 5), ("str", "x"), ("dict", {"check_uniqueness": False}), ("object", object())]},
            {"x0": state_table(3)}),
        "MHESettings": (
            MHESettings, lambda: {},
            {"prox_weight": real_table(), "binary_prox_weight": real_table(), "uniqueness_delta": real_table(),
             "certify_time_budget": [g for g in real_table() if g[0] != "None"],
             "solver_options": [("str", "x"), ("list", [1])], "check_uniqueness": [("str", "no"), ("int", 2)],
             "prox_passes": S.int_garbage(1), "certify_max_nodes": S.int_garbage(1)},
            {}),
        "LocationObserver": (
            LocationObserver, lambda: {"bank": _driveline()[0].bank, "Ts": _driveline()[1]},
            {"bank": bad_objects(("a-design", _driveline()[0].design)), "Ts": real_table(), "x0": state_table(3),
             "q0": loc(3)},
            {"x0": state_table(3), "q0": loc(3)}),
        "HybridObserver": (
            HybridObserver, lambda: {"bank": _driveline()[0].bank, "design": _driveline()[0].design, "Ts": _driveline()[1]},
            {"bank": bad_objects(("a-design", _driveline()[0].design)), "design": bad_objects(("a-bank", _driveline()[0].bank)),
             "Ts": real_table(), "x0": state_table(3), "q0": loc(3)},
            {"x0": state_table(3), "q0": loc(3)}),
        "ContinuousObserver": (
            ContinuousObserver, lambda: {"design": _driveline()[0].design, "Ts": _driveline()[1]},
            {"design": bad_objects(("a-bank", _driveline()[0].bank)), "Ts": real_table(), "x0": state_table(3),
             "location": loc(3)},
            {"x0": state_table(3), "q0": loc(3)}),
        "SlidingModeObserver": (
            SlidingModeObserver, lambda: {"system": _sliding().form, "Ts": _sliding().observer.Ts},
            {"system": bad_objects(("a-pwa-system", _powertrain()[0])), "Ts": real_table(),
             "filter_tau": [g for g in real_table() if g[0] != "None"], "hold": S.int_garbage(1),
             "gains": [("str", "x"), ("nan", np.full(3, np.nan)), ("negative", -np.ones(3)), ("short", np.ones(2)),
                       ("complex", np.ones(3) * 1j)]},
            {"x0": state_table(3)}),
        "SwitchedGainObserver": (
            SwitchedGainObserver, lambda: {"system": _switched()[0].system, "gains": _switched()[0].regions, "dt": _switched()[1]},
            {"system": bad_objects(("an-automaton", _driveline()[0].automaton)),
             "gains": [("empty", []), ("int", 5), ("str", "x"), ("list-of-int", [5]), ("None", None)],
             "dt": real_table(), "init_samples": S.int_garbage(1), "init_state": [("unknown", "nosuch"), ("int", 5), ("None", None)],
             "substeps": S.int_garbage(1), "clip_to_box": [("str", "no")],
             "periodic": [("unknown-state", {"nosuch": 1.0}), ("negative", {"z": -1.0}), ("nan", {"z": math.nan}),
                          ("str-period", {"z": "x"}), ("int", 5), ("str", "z")]},
            {"x0": state_table(3), "q0": S.int_garbage(0, len(_switched()[0].regions) - 1)}),
        "DriftObserver": (
            DriftObserver, lambda: {"system": _drift()["system"], "gains": _drift()["gains"]},
            {"system": bad_objects(("a-periodic-system", _periodic()[1])),
             "gains": [("str", "x"), ("nan", np.full((2, 2), np.nan)), ("shape", np.ones((3, 5))), ("complex", np.ones((2, 2)) * 1j),
                       ("int", 5)],
             "project": [("str", "no")], "max_time_step": real_table()},
            {"x0": state_table(3), "t0": S.real_garbage(positive=False), "q0": S.int_garbage(1, 4),
             "y0": [("nan", math.nan), ("str", "x"), ("not-an-output", 99)]}),
        "PeriodicObserver": (
            PeriodicObserver, lambda: {"periodic": _periodic()[1], "gains": _periodic()[2]},
            {"periodic": bad_objects(("a-drift-system", _periodic()[0])),
             "gains": [("str", "x"), ("nan", np.full((2, 2), np.nan)), ("shape", np.ones((3, 5))), ("complex", np.ones((2, 2)) * 1j),
                       ("int", 5)],
             "project": [("str", "no")], "max_time_step": real_table()},
            {"x0": state_table(2), "t0": S.real_garbage(positive=False), "q0": S.int_garbage(1, 4)}),
    }
    return specs


@functools.cache
def specs():
    return observer_specs()


OBSERVERS = ("LookupObserver", "MHEObserver", "LocationObserver", "HybridObserver", "ContinuousObserver",
             "SlidingModeObserver", "SwitchedGainObserver", "DriftObserver", "PeriodicObserver")


def try_observer(value) -> tuple[str, str]:
    kind, where, which = value
    ctor, valid, args, _ = specs()[kind]
    arg = pick(sorted(args), where)
    label, g = args[arg][which % len(args[arg])]
    kw = valid()
    kw[arg] = g
    outcome, detail = attempt(lambda: ctor(**kw))
    return outcome, f"{kind}({arg} = {label} {describe(g, 60)}): {detail}"


@functools.cache
def reset_instance(kind: str):
    ctor, valid, _, _ = specs()[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ctor(**valid())


def try_reset(value) -> tuple[str, str]:
    kind, where, which = value
    _, _, _, resets = specs()[kind]
    arg = pick(sorted(resets), where)
    label, g = resets[arg][which % len(resets[arg])]
    obs = reset_instance(kind)
    extra = {}
    if kind in ("DriftObserver", "PeriodicObserver") and arg != "t0":
        extra["t0"] = 0.0
    outcome, detail = attempt(lambda: obs.reset(**{arg: g}, **extra))
    return outcome, f"{kind}.reset({arg} = {label} {describe(g, 60)}): {detail}"


# ---------------------------------------------------------------------------------- the family

def _value(names) -> st.SearchStrategy:
    return st.tuples(st.sampled_from(names), st.floats(0.0, 1.0, exclude_max=True, allow_nan=False), st.integers(0, 63))


def _site(kind: str) -> st.SearchStrategy:
    return st.tuples(st.just(kind), st.floats(0.0, 1.0, exclude_max=True, allow_nan=False), st.integers(0, 63))


FAMILY = Family(
    "constructors",
    "every garbage input refused with ModelError",
    [
        Target("system classes of the examples", _value(EXAMPLES), try_system, 60),
        Target("Polytope and Polytope.from_box",
               st.one_of(st.tuples(st.just("init"), st.sampled_from(("A", "b", "names")), st.integers(0, 63)),
                         st.tuples(st.just("from_box"), st.sampled_from(("lower", "upper", "names")), st.integers(0, 63))),
               try_polytope, 30),
        *[Target(f"{kind}(...)", _site(kind), try_observer, 8) for kind in OBSERVERS + ("MHESettings",)],
        *[Target(f"{kind}.reset(...)", _site(kind), try_reset, 6) for kind in OBSERVERS],
    ],
)


#: Targets where the fuzz finds a defect today (strict: fixing the defects turns them into failures to remove).
#: Empty: every target passes (issue 16); a new defect goes here, target name -> what it is.
KNOWN_DEFECTS: dict[str, str] = {}


@pytest.mark.parametrize("target", [pytest.param(t, id=t.name, marks=[pytest.mark.xfail(strict=True, reason=KNOWN_DEFECTS[t.name])]
                                                 if t.name in KNOWN_DEFECTS else []) for t in FAMILY.targets])
def test_garbage_is_refused(target):
    assert_no_bugs(run_target(target))


def test_the_valid_bases_build():
    """Each garbage input changes one field of a valid input: the unchanged inputs are accepted."""
    from hybobs_opt.systems import Polytope

    for name in EXAMPLES:
        sysm = example_system(name)
        assert rebuild(sysm).to_dict() == sysm.to_dict()
    Polytope.from_box([-1.0, -2.0, 0.0], [1.0, 2.0, 3.0], ("a", "b", "c"))
    for kind in OBSERVERS:
        obs = reset_instance(kind)
        obs.reset(**({"t0": 0.0} if kind in ("DriftObserver", "PeriodicObserver") else {}))


# ---------------------------------------------------------------------------------- the defects, one line each

def _ctor(kind, **changes):
    def call():  # the specs build example systems: at test time, not at collection
        ctor, valid, _, _ = specs()[kind]
        return ctor(**{**valid(), **changes})
    return call


def _reset(kind, **kwargs):
    return lambda: reset_instance(kind).reset(**kwargs)


#: ``(id, call)``: each call must raise ModelError; today each one does not (strict xfails).  Empty: each
#: defect found so far is fixed and its call is a test of :data:`FIXED`.
DEFECTS: list = []


#: Defects of this table that are fixed: each call raises ModelError now (ordinary tests).
FIXED = [
    ("reset-bool-x0", _reset("SlidingModeObserver", x0=np.ones(3, dtype=bool))),
    ("ctor-bool-x0", _ctor("MHEObserver", x0=np.ones(3, dtype=bool))),
    ("location-reset-q0-True", _reset("LocationObserver", q0=True)),
    ("switched-clip_to_box-str", _ctor("SwitchedGainObserver", clip_to_box="no")),
    ("switched-substeps-float", _ctor("SwitchedGainObserver", substeps=1.0)),
    ("switched-gains-str", _ctor("SwitchedGainObserver", gains="x")),
    ("switched-gains-list-of-int", _ctor("SwitchedGainObserver", gains=[5])),
    ("drift-project-str", _ctor("DriftObserver", project="no")),
    ("drift-max_time_step-complex", _ctor("DriftObserver", max_time_step=0.1 + 0.1j)),
    ("drift-gains-complex", _ctor("DriftObserver", gains=np.ones((2, 2)) * 1j)),
    ("periodic-project-str", _ctor("PeriodicObserver", project="no")),
    ("periodic-max_time_step-array", _ctor("PeriodicObserver", max_time_step=np.array([0.1, 0.2]))),
    ("periodic-gains-complex", _ctor("PeriodicObserver", gains=np.ones((2, 2)) * 1j)),
    ("sliding-filter_tau-complex", _ctor("SlidingModeObserver", filter_tau=0.1 + 0.1j)),
    ("sliding-filter_tau-array", _ctor("SlidingModeObserver", filter_tau=np.array([0.1, 0.2]))),
    ("sliding-gains-complex", _ctor("SlidingModeObserver", gains=np.ones(3) * 1j)),
    ("sliding-hold-True", _ctor("SlidingModeObserver", hold=True)),
    ("sliding-Ts-True", _ctor("SlidingModeObserver", Ts=True)),
    ("lookup-analysis-None", _ctor("LookupObserver", analysis=None)),
    ("lookup-progress-str", _ctor("LookupObserver", progress="x")),
    ("lookup-b_tilde-int", _ctor("LookupObserver", b_tilde=5)),
    ("lookup-analysis-object", _ctor("LookupObserver", analysis=object())),
    ("lookup-b_tilde-list-of-int", _ctor("LookupObserver", b_tilde=[5])),
    ("location-bank-str", _ctor("LocationObserver", bank="x")),
    ("hybrid-design-is-a-bank", lambda: _ctor("HybridObserver", design=_driveline()[0].bank)()),
    ("continuous-design-str", _ctor("ContinuousObserver", design="x")),
    ("continuous-location-complex", _ctor("ContinuousObserver", location=1j)),
    ("location-bank-object", _ctor("LocationObserver", bank=object())),
    ("hybrid-bank-str", _ctor("HybridObserver", bank="x")),
    ("continuous-design-object", _ctor("ContinuousObserver", design=object())),
    ("continuous-Ts-True", _ctor("ContinuousObserver", Ts=True)),
]


@pytest.mark.parametrize("call", [pytest.param(c, id=i) for i, c in FIXED])
def test_fixed_defect(call):
    outcome, detail = attempt(call)
    assert outcome == "ModelError", detail


@pytest.mark.parametrize("call", [pytest.param(c, id=i, marks=pytest.mark.xfail(strict=True, reason="defect found by the fuzz"))
                                  for i, c in DEFECTS])
def test_defect(call):
    outcome, detail = attempt(call)
    assert outcome == "ModelError", detail
