"""Every public callable that takes ``**kwargs`` refuses a keyword it does not know.

A misspelt keyword must be an error, not a silent default (python-control checks the same).  The
observers' ``reset`` takes the keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call
resets any observer: each ignores those it has no use for) and refuses every other;
``MHEObserver`` takes the fields of ``MHESettings`` as deprecated keywords and refuses every other;
the other public ``**kwargs`` callables pass their keywords to a function with a fixed signature.
The list below is complete: a new public ``**kwargs`` callable fails the inventory test until it
is added with a check of its own.
"""

from __future__ import annotations

import ast
import importlib
import inspect
from pathlib import Path

import numpy as np
import pytest

from canonical import deadzone_spring

from hybobs_opt.contract import RESET_KEYWORDS
from hybobs_opt.errors import ModelError

PACKAGE = Path(__file__).resolve().parents[3] / "hybobs_opt"
PUBLIC = ("hybobs_opt", "hybobs_opt.systems", "hybobs_opt.geometry", "hybobs_opt.regions", "hybobs_opt.synthesis", "hybobs_opt.lmi",
          "hybobs_opt.mhe", "hybobs_opt.observers", "hybobs_opt.sim", "hybobs_opt.contract")

#: Public ``**kwargs`` callables other than ``reset`` and how each refuses an unknown keyword.
OTHER_KWARGS = {
    "AugmentedSystem.at": "the builder's signature (TypeError)",
    "MHEObserver.__init__": "ModelError naming the keyword (the deprecated MHESettings fields warn and are folded in)",
    "ObserverLMI.bounds": "jacobian_bounds' signature (TypeError)",
    "WindowResult.replace": "dataclasses.replace (TypeError)",
    "Certificate.__init__": "a typing.Protocol: never instantiated",
    "SolveResult.__init__": "a typing.Protocol: never instantiated",
}


def public_kwargs_callables() -> set[str]:
    found = set()
    for name in PUBLIC:
        mod = importlib.import_module(name)
        for attr in getattr(mod, "__all__", []):
            obj = getattr(mod, attr)
            members = [(attr, obj)] if not inspect.isclass(obj) else [
                (f"{attr}.{k}", v) for k, v in vars(obj).items() if callable(v) and (not k.startswith("_") or k == "__init__")]
            for label, fn in members:
                try:
                    sig = inspect.signature(fn)
                except (TypeError, ValueError):
                    continue
                if any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()):
                    found.add(label)
    return found


def test_every_public_kwargs_callable_is_accounted_for():
    found = public_kwargs_callables()
    resets = {f for f in found if f.endswith(".reset")}
    assert found - resets - set(OTHER_KWARGS) == set()
    assert len(resets) >= 12


def reset_methods_without_the_check() -> list[str]:
    """``file:line`` of every ``def reset(..., **kwargs)`` in the package whose first statement
    after the docstring is not ``check_reset_keywords(kwargs, ...)``."""
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not (isinstance(node, ast.FunctionDef) and node.name == "reset" and node.args.kwarg is not None):
                continue
            if any(getattr(d, "id", getattr(d, "attr", "")) == "abstractmethod" for d in node.decorator_list):
                continue  # the contract's declaration (Observer.reset)
            body = node.body[1:] if ast.get_docstring(node) is not None else node.body
            first = body[0] if body else None
            ok = (isinstance(first, ast.Expr) and isinstance(first.value, ast.Call)
                  and getattr(first.value.func, "id", "") == "check_reset_keywords"
                  and isinstance(first.value.args[0], ast.Name) and first.value.args[0].id == node.args.kwarg.arg)
            if not ok:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    return bad


def test_every_reset_with_kwargs_checks_them_first():
    assert reset_methods_without_the_check() == []


@pytest.fixture(scope="module")
def observers():
    from hybobs_opt import LookupObserver, MHEObserver, SetMembershipFilter, SetMembershipObserver
    from hybobs_opt.observers import NoiseAwareLookupObserver
    from hybobs_opt.observers.kalman import ModeSequenceKalmanFilter
    from hybobs_opt.regions import analyse_observability

    plant = deadzone_spring()
    analysis = analyse_observability(plant, 3)
    return {"lookup": LookupObserver(analysis), "noise-lookup": NoiseAwareLookupObserver(analysis, noise_std=0.01),
            "miqp": MHEObserver(plant, 3), "set-membership": SetMembershipObserver(plant, 3, 0.01),
            "set-filter": SetMembershipFilter(plant, 0.01), "kalman": ModeSequenceKalmanFilter(plant, 0.01)}


@pytest.mark.parametrize("kind", ["lookup", "noise-lookup", "miqp", "set-membership", "set-filter", "kalman"])
def test_reset_refuses_a_misspelt_keyword_and_takes_the_shared_ones(observers, kind):
    obs = observers[kind]
    with pytest.raises(ModelError, match="qo"):
        obs.reset(np.zeros(2), qo=1)
    with pytest.raises(ModelError, match="location"):  # an old name of another observer's keyword
        obs.reset(np.zeros(2), location=1)
    shared = {"q0": 0, "t0": 0.0, "y0": None, "P0": None, "k0": 0}
    assert set(shared) == set(RESET_KEYWORDS)
    obs.reset(np.zeros(2), **shared)  # one call resets any observer
    est = obs.step(np.zeros(1), np.zeros(1))
    assert est.flag in ("warming_up", "observable", "unobservable", "fallback")


def test_the_other_kwargs_callables_refuse_unknown_keywords():
    from hybobs_opt.mhe import MHEObserver, WindowResult
    from hybobs_opt.status import Status

    with pytest.raises(ModelError, match="chek_uniqueness"):
        MHEObserver(deadzone_spring(), 3, chek_uniqueness=False)
    with pytest.warns(FutureWarning, match=r"MHEObserver\(check_uniqueness=\.\.\.\) is deprecated"):
        assert MHEObserver(deadzone_spring(), 3, check_uniqueness=False).settings.check_uniqueness is False

    with pytest.raises(TypeError):
        WindowResult(Status.OPTIMAL).replace(nosuch=1)
    from hybobs_opt.lmi import ObserverLMI
    from hybobs_opt.studies import get_example

    lmi = ObserverLMI(get_example("vehicle_tracking").build())
    with pytest.raises(TypeError):
        lmi.bounds(samplez=10)
