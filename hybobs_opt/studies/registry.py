"""The registry of the seed papers' example systems.

Each study package (``studies/paper000_driveline`` ...) calls :func:`register` with an
:class:`Example`: a factory for the system, the paper's simulation scenario, and the metadata the
CLI prints (``hybobs examples --json``).  Factories and scenarios may be given as
``"module:function"`` references, imported on first call: listing the examples then costs no
import of the systems, the simulators or any solver (``hybobs examples`` starts in well under a
second).  Example names and state names are a contract (saved files and scripts name them): keep them stable.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from hybobs_opt.errors import ModelError

#: Short labels of the five seed papers (``../shared/seeds``).
PAPERS: dict[str, str] = {
    "000": "Balluchi et al., hybrid observer for a driveline with discontinuous elasticity",
    "001": "Djemai, Manamanni, Barbot, sliding-mode observer for nonlinear hybrid systems",
    "002": "Observability and deadbeat observers for PWA powertrains with backlash",
    "003": "Observer design for piecewise affine hybrid systems with constant drift",
    "004": "Rajamani et al., switched-gain observers for non-monotonic nonlinear systems",
}


class LazyCallable:
    """A ``"package.module:function"`` reference that imports and calls the function on first use.

    See Also
    --------
    Example : its ``build`` and ``scenario`` may be given so.

    Examples
    --------
    >>> from hybobs_opt.studies import LazyCallable
    >>> hypot = LazyCallable("math:hypot")               # nothing is imported yet
    >>> hypot
    LazyCallable('math:hypot')
    >>> hypot(3, 4)
    5.0
    """

    __slots__ = ("reference", "_fn")

    def __init__(self, reference: str) -> None:
        module, sep, name = reference.partition(":")
        if not sep or not module or not name:
            raise ModelError("example factory reference", "'package.module:function'", repr(reference))
        self.reference = reference
        self._fn: Callable[..., Any] | None = None

    def resolve(self) -> Callable[..., Any]:
        """The referenced function (imported once).

        Returns
        -------
        callable
            The imported function.
        """
        if self._fn is None:
            module, _, name = self.reference.partition(":")
            self._fn = getattr(importlib.import_module(module), name)
        return self._fn

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.resolve()(*args, **kwargs)

    def __repr__(self) -> str:
        return f"LazyCallable({self.reference!r})"


@dataclass(frozen=True)
class Example:
    """One example system of a seed paper.

    Attributes
    ----------
    name : str
        Stable identifier (``powertrain3``, ``traffic_junction``, ...).
    kind : str
        System class: ``"pwa"``, ``"hybrid_automaton"``, ``"constant_drift"`` or ``"scalar_nonlinear"``.
    paper : str
        Seed-paper key (``"002"``) into :data:`PAPERS`.
    summary : str
        One line for ``hybobs examples``.
    state_names : tuple of str
        Names of the states, as the paper names them.
    build : callable or str
        ``build(**params) -> system``; keyword parameters documented in the factory.  A string
        ``"module:function"`` is imported on first call (:class:`LazyCallable`).
    scenario : callable or str
        ``scenario(system, t_final=None) -> Trace``: the paper's simulation scenario (callable or
        ``"module:function"``).
    default_t_final : float
        Horizon of the scenario when ``t_final`` is not given (seconds).
    params : dict
        Default keyword parameters of ``build`` (e.g. ``{"gear_ratio": 1/12}``).
    sample_time : float, optional
        Sample period of the scenario's trace (seconds; events may add samples): the scenario up
        to ``t_final`` has about ``t_final / sample_time`` samples (checked against
        :data:`hybobs_opt.limits.MAX_SAMPLES` before it runs).  ``None``: not declared.
    observers : tuple of str
        The observer kinds of the example's observer scenario (``hybobs observe NAME``), the
        default first; empty: not declared (the scenario checks the kind itself).
    observer_filter : bool
        Whether the observer scenario has a low-pass filtered variant (paper 001's observers).
    state_units : tuple of str
        The unit of each state as its paper gives it (``"rad/s"``, ``"vehicles"``; ``""`` for a
        dimensionless state), used on the axes of the figures (:meth:`state_label`); empty: none
        declared.

    See Also
    --------
    get_example : one example by name.
    list_examples : all of them.
    hybobs_opt.sim.simulate_system : simulate a built system with other settings.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> example = get_example("powertrain3")
    >>> example.paper, example.kind, example.state_names
    ('002', 'pwa', ('theta', 'omega_m', 'omega_l'))
    >>> example.state_label("omega_m"), example.params
    ('omega_m [rad/s]', {'gear_ratio': 0.08333333333333333})
    >>> plant = example.build(gear_ratio=1 / 2)          # the system, with other parameters
    >>> trace = example.simulate()                       # the paper's scenario
    >>> trace.x.shape
    (3000, 3)
    """

    name: str
    kind: str
    paper: str
    summary: str
    state_names: tuple[str, ...]
    build: Callable[..., Any]
    scenario: Callable[..., Any]
    default_t_final: float
    params: dict[str, Any] = field(default_factory=dict)
    sample_time: float | None = None
    observers: tuple[str, ...] = ()
    observer_filter: bool = False
    state_units: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.state_units and len(self.state_units) != len(self.state_names):
            raise ModelError("Example.state_units", f"one unit per state ({len(self.state_names)})",
                             f"{len(self.state_units)} units")
        for name in ("build", "scenario"):
            value = getattr(self, name)
            if isinstance(value, str):
                object.__setattr__(self, name, LazyCallable(value))
            elif not callable(value):
                raise ModelError(f"Example.{name}", "a callable or a 'module:function' string", repr(value))

    @property
    def n_states(self) -> int:
        return len(self.state_names)

    def state_unit(self, name: str) -> str:
        """The unit of state ``name`` (``""`` when dimensionless or not declared).

        Parameters
        ----------
        name : str
            A state name of the example.

        Returns
        -------
        str
        """
        if name not in self.state_names:
            raise ModelError("state name", f"one of {self.state_names}", repr(name))
        return self.state_units[self.state_names.index(name)] if self.state_units else ""

    def state_label(self, name: str) -> str:
        """Axis label of state ``name``: ``"omega_m [rad/s]"``, or the bare name without a unit.

        Parameters
        ----------
        name : str
            A state name of the example.

        Returns
        -------
        str
        """
        from hybobs_opt.plotting import quantity_label

        return quantity_label(name, self.state_unit(name))

    def check_t_final(self, t_final: float) -> None:
        """``ModelError("t_final")`` unless the scenario up to ``t_final`` has at least one sample period
        and at most :data:`hybobs_opt.limits.MAX_SAMPLES` samples (checked before anything runs)."""
        import math

        from hybobs_opt.limits import check_samples

        if not (isinstance(t_final, (int, float)) and math.isfinite(t_final) and t_final > 0):
            raise ModelError("t_final", "a positive finite time in seconds", repr(t_final))
        if self.sample_time is None:
            return
        if t_final < self.sample_time:
            raise ModelError("t_final", f"at least one sample period of the scenario of {self.name!r} "
                             f"({self.sample_time:g} s)", repr(t_final))
        check_samples(t_final / self.sample_time + 1, "t_final",
                      f"t_final = {t_final:g} s at the scenario's sample period {self.sample_time:g} s")

    def simulate(self, t_final: float | None = None, **params: Any):
        """Build the system with ``params`` and run the paper's scenario up to ``t_final``.

        Returns
        -------
        Trace
            The scenario's trajectory.
        """
        unknown = set(params) - set(self.params)
        if unknown:
            raise ModelError(
                f"parameters of example {self.name!r}",
                f"names among {sorted(self.params) or 'none'}",
                f"{sorted(unknown)}",
            )
        if t_final is not None:
            self.check_t_final(t_final)
        system = self.build(**params)
        return self.scenario(system, t_final=self.default_t_final if t_final is None else t_final)

    def to_dict(self) -> dict[str, Any]:
        """The ``hybobs examples --json`` record.

        Returns
        -------
        dict
            The example's name, kind, paper (and its title), summary, states, parameters, default
            horizon, sample time and observer kinds.
        """
        return {
            "name": self.name,
            "kind": self.kind,
            "paper": self.paper,
            "paper_title": PAPERS.get(self.paper, ""),
            "summary": self.summary,
            "n_states": self.n_states,
            "state_names": list(self.state_names),
            "state_units": list(self.state_units) or [""] * self.n_states,
            "params": {k: v for k, v in self.params.items()},
            "default_t_final": self.default_t_final,
            "sample_time": self.sample_time,
            "observers": list(self.observers),
        }


_REGISTRY: dict[str, Example] = {}


def register(example: Example) -> Example:
    """Add ``example`` to the registry (names must be unique).

    Returns
    -------
    Example
        ``example`` itself (so it can be used as a decorator's result).

    See Also
    --------
    Example : what is registered.
    get_example : finds it afterwards.

    Examples
    --------
    A variant of a shipped example under a name of its own:

    >>> import dataclasses
    >>> from hybobs_opt.studies import get_example, register
    >>> half = dataclasses.replace(get_example("powertrain3"), name="powertrain3_half_gear",
    ...                            params={"gear_ratio": 0.5})
    >>> register(half) is half
    True
    >>> get_example("powertrain3_half_gear").params
    {'gear_ratio': 0.5}
    """
    if example.name in _REGISTRY:
        raise ModelError("example name", "a unique name", f"duplicate {example.name!r}")
    _REGISTRY[example.name] = example
    return example


def get_example(name: str) -> Example:
    """Look an example up by name; the error lists the valid names.

    Returns
    -------
    Example
        The registered example; ``build()`` gives its system, ``simulate()`` its scenario.

    See Also
    --------
    list_examples : every registered example.
    hybobs_opt.systems.get_example : the same across every installed catalogue.

    Examples
    --------
    >>> from hybobs_opt.studies import get_example
    >>> get_example("traffic_junction").summary
    'Signalized 3-flow T-junction, clearing policy; sensor on lane 1 only (Sec. 5)'
    >>> get_example("powertrain")
    Traceback (most recent call last):
    ...
    hybobs_opt.errors.ModelError: example: expected one of [...], got 'powertrain'
    """
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ModelError("example", f"one of {sorted(_REGISTRY)}", repr(name)) from None


def list_examples() -> list[Example]:
    """All registered examples, in registration order (papers 000 to 004).

    Returns
    -------
    list of Example
        The registered examples.

    See Also
    --------
    get_example : one by name.
    register : add one.

    Examples
    --------
    >>> from hybobs_opt.studies import list_examples
    >>> [(example.name, example.paper) for example in list_examples()][:5]
    [('driveline', '000'), ('switched_unstable', '001'), ('triangular', '001'), ('double_scroll', '001'), ('powertrain3', '002')]
    """
    return list(_REGISTRY.values())


def resolve_example(name: str, params: dict[str, Any]):
    """Resolver of example names for :mod:`hybobs_opt.systems.resolve` (``None`` for other names)."""
    if name not in _REGISTRY:
        return None
    return _REGISTRY[name].build(**params)
