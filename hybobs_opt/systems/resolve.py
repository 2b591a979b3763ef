"""Naming a system: one way for the command line, saved results and scripts.

A name is one of

* a name known to a resolver registered with :func:`register_resolver`, or to an installed
  example catalogue (:mod:`hybobs_opt.systems.catalogue`: this package's seed-paper examples,
  and any other distribution's, found through an entry point);
* a model file ``PATH.toml``, ``PATH.yaml``/``.yml`` or ``PATH.json``
  (:mod:`hybobs_opt.systems.model_file`); parameters are refused, a file has none;
* ``PATH.py:FUNCTION``: the file is loaded as a module and ``FUNCTION(**params)`` is called;
* ``package.module:FUNCTION``: the module is imported and ``FUNCTION(**params)`` is called.

The last three forms run code or read files the name points to: they are for names the user
passes (the command line, a call).  A name read from a saved file goes through
:func:`resolve_registered`, which accepts registered names only.

Whatever a function returns must be a system object (PWA, hybrid automaton, constant-drift or
scalar-nonlinear); anything else, an import that fails or a function that raises, is a
:class:`~hybobs_opt.errors.ModelError` naming the file or module and the function.  The core never
imports the studies: they plug in here.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..errors import HybobsError, ModelError

#: ``resolver(name, params) -> system or None`` (``None``: not a name it knows).
Resolver = Callable[[str, dict[str, Any]], Any]

_RESOLVERS: list[tuple[str, Resolver]] = []


def register_resolver(label: str, resolver: Resolver) -> None:
    """Add (or replace, by ``label``) a resolver of system names.

    Parameters
    ----------
    label : str
        Name of the resolver (shown in error messages); a resolver already registered under it is
        replaced.
    resolver : callable
        ``resolver(name, params) -> system or None``; ``None`` means the name is not one it knows.

    See Also
    --------
    resolve_system : asks every resolver.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import register_resolver, resolve_system
    >>> def my_systems(name, params):
    ...     if name == "my_powertrain":
    ...         return get_example("powertrain3").build(gear_ratio=0.5, **(params or {}))
    ...     return None                                     # not one of mine
    >>> register_resolver("my systems", my_systems)
    >>> resolve_system("my_powertrain").name
    'powertrain3 (tau=0.5)'
    """
    _RESOLVERS[:] = [(k, r) for k, r in _RESOLVERS if k != label]
    _RESOLVERS.append((label, resolver))


_CATALOGUES_REGISTERED = False


def _resolvers() -> list[tuple[str, Resolver]]:
    """The registered resolvers, with every installed example catalogue's (loaded on first use)."""
    global _CATALOGUES_REGISTERED
    if not _CATALOGUES_REGISTERED:
        from .catalogue import example_catalogues

        for label, catalogue in example_catalogues():
            if not any(k == label for k, _ in _RESOLVERS):
                _RESOLVERS.append((label, catalogue.resolve_example))
        _CATALOGUES_REGISTERED = True
    return list(_RESOLVERS)


def system_classes() -> tuple[type, ...]:
    """The classes a named system may be an instance of."""
    from .constant_drift import ConstantDriftSystem
    from .hybrid import HybridAutomaton
    from .pwa import PWASystem
    from .scalar_nonlinear import ScalarNonlinearSystem

    return (PWASystem, HybridAutomaton, ConstantDriftSystem, ScalarNonlinearSystem)


def resolve_system(name: str, params: dict[str, Any] | None = None) -> Any:
    """The system called ``name``, built with ``params`` (see the module docstring for the forms).

    Parameters
    ----------
    name : str
        A registered name (e.g. an example), a model file, ``PATH.py:FUNCTION`` or
        ``package.module:FUNCTION``.
    params : mapping of str to object, optional
        Keyword arguments of the builder (refused for a model file).

    Returns
    -------
    object
        The system (any system class).

    Raises
    ------
    ModelError
        ``name`` is none of the forms, the file or module cannot be loaded, the function raises
        or returns something that is not a system; the message names the file and entry.

    See Also
    --------
    register_resolver : teach it more names.
    load_model : the model-file form.

    Examples
    --------
    The names every command line accepts: an example name, a model file, ``PATH.py:FUNCTION`` or
    ``module:FUNCTION``:

    >>> from hybobs_opt.systems import resolve_system
    >>> resolve_system("powertrain3", {"gear_ratio": 0.5})
    PWASystem(name='powertrain3 (tau=0.5)', n=3, m=1, p=1, modes=3)
    >>> resolve_system("hybobs_opt.studies.paper002_powertrain.systems:powertrain3").name
    'powertrain3 (tau=0.08333)'
    """
    from .model_file import is_model_path, load_model

    if params is not None and not isinstance(params, Mapping):
        raise ModelError("params", "a mapping of parameter names to values (or None)", f"{type(params).__name__}")
    params = dict(params or {})
    bad = [k for k in params if not isinstance(k, str) or not k.isidentifier()]
    if bad:
        raise ModelError("params", "parameter names that are identifiers (keyword arguments of the builder)", repr(bad[0]))
    if not isinstance(name, str) or not name.strip():
        raise ModelError("system name", "a non-empty string (an example name, a model file, PATH.py:FUNCTION or "
                         "module:FUNCTION)", repr(name))
    resolvers = _resolvers()
    for label, resolver in resolvers:
        try:
            system = resolver(name, params)
        except HybobsError:
            raise
        except Exception as exc:  # an unknown keyword (TypeError), or whatever the builder raises
            raise ModelError(f"{name}: params" if isinstance(exc, TypeError) and "argument" in str(exc) else name,
                             f"parameters the {label} builder accepts, and a builder that runs without error",
                             f"{type(exc).__name__}: {exc}") from None
        if system is not None:
            return system
    if is_model_path(name):
        if params:
            raise ModelError(f"{name}: params", "no parameters (a model file has fixed values; edit the file)",
                             f"{sorted(params)}")
        return load_model(name)
    target, sep, function = name.rpartition(":")
    if sep and target and function:
        if target.endswith(".py") or "/" in target or "\\" in target:
            fn = _function_from_file(target, function)
        else:
            fn = _function_from_module(target, function)
        return _call_builder(fn, name, params)
    known = ", ".join(label for label, _ in resolvers) or "none registered"
    hint = " (no such file)" if name.endswith(".py") or "/" in name else ""
    raise ModelError("system name", f"a name known to a resolver ({known}), a model file (.toml, .yaml, .json), "
                     f"PATH.py:FUNCTION or module:FUNCTION", repr(name) + hint)


def resolve_registered(name: str, params: dict[str, Any] | None = None, *, source: str = "a saved file") -> Any:
    """The system called ``name`` by a registered resolver (an example of the library), and nothing else.

    The form for names that come from a file: a saved file never names code, so ``module:FUNCTION``,
    ``PATH.py:FUNCTION`` and model paths -- which :func:`resolve_system` accepts from the command
    line or a call -- are refused here before anything is imported or read.

    Parameters
    ----------
    name : str
        A name registered with :func:`register_resolver`.
    params : mapping of str to object, optional
        Keyword arguments of the builder.
    source : str
        Where the name came from (for the message).

    Raises
    ------
    ModelError
        ``name`` is no registered name, or its builder refuses ``params``.
    """
    from .model_file import is_model_path

    if not isinstance(name, str) or not name.strip() or ":" in name or is_model_path(name) or "/" in name \
            or "\\" in name or name.endswith(".py"):
        raise ModelError("example", f"the name of a registered example in {source} (a saved file never names code or "
                         "files to load: pass a module:FUNCTION or a model file yourself, on the command line or "
                         "in a call)", repr(name))
    resolvers = _resolvers()
    known = [label for label, _ in resolvers]
    system = None
    for label, resolver in resolvers:
        try:
            system = resolver(name, dict(params or {}))
        except HybobsError:
            raise
        except Exception as exc:
            raise ModelError(f"{name}: params", f"parameters the {label} builder accepts", f"{type(exc).__name__}: {exc}") from None
        if system is not None:
            return system
    raise ModelError("example", f"the name of a registered example in {source} (resolvers: {', '.join(known) or 'none'})",
                     repr(name))


def _function_from_file(path_text: str, function: str) -> Callable:
    path = Path(path_text)
    if path.suffix != ".py":
        raise ModelError(f"{path_text}:{function}", "PATH.py:FUNCTION (a Python file)", f"the file {path_text!r}")
    if not path.is_file():
        raise ModelError(f"{path_text}:{function}", "an existing Python file", f"no file {str(path)!r}")
    module_name = f"hybobs_user_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module  # dataclasses and pickling look the module up by name
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # whatever the user's file raises on import
        sys.modules.pop(module_name, None)
        raise ModelError(str(path), "a Python file that imports without error", f"{type(exc).__name__}: {exc}") from None
    return _attribute(module, function, str(path))


def _function_from_module(module_name: str, function: str) -> Callable:
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:  # ImportError, or whatever the module raises on import
        raise ModelError(f"{module_name}:{function}", "an importable 'module:FUNCTION'", f"{type(exc).__name__}: {exc}") from None
    return _attribute(module, function, module_name)


def _attribute(module, function: str, where: str) -> Callable:
    fn = getattr(module, function, None)
    if fn is None:
        public = sorted(k for k, v in vars(module).items() if callable(v) and not k.startswith("_"))
        raise ModelError(f"{where}:{function}", f"a function defined there (found {', '.join(public) or 'none'})", "no such name")
    if not callable(fn):
        raise ModelError(f"{where}:{function}", "a function returning a system", type(fn).__name__)
    return fn


def _check_text_params(fn: Callable, name: str, params: dict[str, Any]) -> None:
    """``ModelError`` for a string value of a parameter that is not a string parameter of ``fn``
    (annotated ``str`` or with a ``str`` default): no text reaches a numeric parameter."""
    import inspect

    signature = inspect.signature(fn)
    for key, value in params.items():
        if not isinstance(value, str):
            continue
        parameter = signature.parameters.get(key)
        if parameter is None:  # **kwargs: nothing declared
            continue
        annotation = parameter.annotation
        if annotation in (str, "str", "str | None", "Optional[str]") or isinstance(parameter.default, str):
            continue
        raise ModelError(f"{name}: params {key}", "a number (the parameter is not a string: annotate it str or give it "
                         "a str default to pass text)", repr(value))


def _vector_params(fn: Callable, name: str, params: dict[str, Any]) -> dict[str, Any]:
    """Text values (``"1,0"``) of parameters whose default is a tuple of numbers, read as a tuple of
    that many numbers: the default declares the parameter a vector of that length."""
    import inspect

    signature = inspect.signature(fn)
    out = dict(params)
    for key, value in params.items():
        parameter = signature.parameters.get(key)
        default = None if parameter is None else parameter.default
        if not (isinstance(value, str) and isinstance(default, tuple) and default
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in default)):
            continue
        parts = value.split(",")
        try:
            numbers = tuple(float(p) for p in parts)
        except ValueError:
            numbers = ()
        if len(numbers) != len(default) or not all(math.isfinite(v) for v in numbers):
            example = ",".join(str(v) for v in default)
            raise ModelError(f"{name}: params {key}", f"{len(default)} comma-separated finite numbers (a vector "
                             f"parameter, e.g. {key}={example})", repr(value))
        out[key] = numbers
    return out


def _call_builder(fn: Callable, name: str, params: dict[str, Any]) -> Any:
    import inspect

    try:
        inspect.signature(fn).bind(**params)
    except TypeError as exc:
        raise ModelError(f"{name}: params", "parameters the function accepts", str(exc)) from None
    except ValueError:
        pass  # no signature to check (a builtin): the call says
    else:
        params = _vector_params(fn, name, params)
        _check_text_params(fn, name, params)
    try:
        system = fn(**params)
    except HybobsError as exc:
        field = getattr(exc, "field", None)
        if isinstance(exc, ModelError) and field is not None:
            raise ModelError(f"{name}: {field}", exc.expected, exc.got) from None
        raise ModelError(name, "a function that builds a system", f"{type(exc).__name__}: {exc}") from None
    except Exception as exc:  # whatever the user's function raises
        raise ModelError(name, "a function that builds a system without error", f"{type(exc).__name__}: {exc}") from None
    if not isinstance(system, system_classes()):
        raise ModelError(name, "a function returning a PWASystem, HybridAutomaton, ConstantDriftSystem or "
                         "ScalarNonlinearSystem", f"a {type(system).__name__}")
    return system
