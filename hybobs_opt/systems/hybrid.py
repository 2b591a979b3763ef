"""Continuous-time hybrid automata: locations with flows, outputs, invariants and a location graph.

Covers the driveline with discontinuous elasticity of paper 000 (three locations of the elastic
characteristic) and the switched systems of paper 001 (switching decided by a function of the
state).  Affine locations can be discretised exactly (zero-order hold per location) into a
:class:`~hybobs_opt.systems.pwa.PWASystem`, so every PWA-like automaton can also be handed to the
lookup-table deadbeat observer of paper 002.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.linalg import expm

from ..errors import ModelError
from ..tolerances import FULL_DIMENSION_RTOL
from ._model_io import ModelDictMixin
from .._validate import as_int, as_items, as_matrix, as_names, as_text, as_vector, check_finite, probe_callable, real_array
from ..geometry.polytope import Polytope
from .pwa import PWAMode, PWASystem, _or_given, check_coordinate_names

FlowFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Location:
    """One location (discrete state) of a hybrid automaton.

    The flow is affine, ``x' = A x + B u + E`` (give ``A``, and optionally ``B``, ``E``), or
    nonlinear, ``x' = flow(x, u)`` (give ``flow``).  The output is ``y = C x + D u + c`` or
    ``output(x, u)``.  The invariant is the region of the state (``dim n``) or of ``(x, u)``
    (``dim n + m``) where the location is active.

    Parameters
    ----------
    name : str
    invariant : Polytope
    A, B, E : arrays, optional
        Affine flow data.
    C, D, c : arrays, optional
        Affine output data.
    flow : callable, optional
        ``flow(x, u) -> dx`` for nonlinear flows (then ``A`` must be ``None``).
    output : callable, optional
        ``output(x, u) -> y`` for nonlinear outputs (then ``C`` must be ``None``).

    See Also
    --------
    HybridAutomaton : the automaton of several locations.
    Edge : a transition between locations.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import Location
    >>> below = Location("below", Polytope(np.array([[1.0]]), np.array([0.0])),        # invariant x <= 0
    ...                  A=np.array([[-1.0]]), E=np.array([1.0]), C=np.array([[1.0]]))  # x' = 1 - x, y = x
    >>> below.name, below.invariant.contains(np.array([-1.0]))
    ('below', True)
    """

    name: str
    invariant: Polytope
    A: np.ndarray | None = None
    B: np.ndarray | None = None
    E: np.ndarray | None = None
    C: np.ndarray | None = None
    D: np.ndarray | None = None
    c: np.ndarray | None = None
    flow: FlowFn | None = None
    output: FlowFn | None = None

    @property
    def is_affine(self) -> bool:
        """True when both the flow and the output are affine (so :meth:`HybridAutomaton.discretize` applies)."""
        return self.A is not None and self.C is not None

    def __post_init__(self) -> None:
        # Types only: the shapes are checked against the automaton's (n, m, p) by validated().
        as_text(self.name, "Location.name")
        label = f"Location {self.name!r}"
        if not isinstance(self.invariant, Polytope):
            raise ModelError(f"{label}.invariant", "a Polytope over x or over (x, u)", type(self.invariant).__name__)
        if (self.A is None) == (self.flow is None):
            raise ModelError(f"{label}.flow", "exactly one of an affine flow (A, B, E) or a callable flow", "both or neither")
        if (self.C is None) == (self.output is None):
            raise ModelError(f"{label}.output", "exactly one of an affine output (C, D, c) or a callable output",
                             "both or neither")
        for key, fn, what in (("flow", self.flow, "flow(x, u) -> dx"), ("output", self.output, "output(x, u) -> y")):
            if fn is not None and not callable(fn):
                raise ModelError(f"{label}.{key}", f"a callable {what}", type(fn).__name__)
        for key in ("A", "B", "E", "C", "D", "c"):
            value = getattr(self, key)
            if value is not None:
                arr = real_array(value, f"{label}.{key}", "a numeric matrix" if key in "ABCD" else "a numeric vector")
                arr.setflags(write=False)
                object.__setattr__(self, key, arr)
        if self.A is None and (self.B is not None or self.E is not None):
            raise ModelError(f"{label}.B", "no B or E with a callable flow (they belong to the affine flow)", "a matrix")
        if self.C is None and (self.D is not None or self.c is not None):
            raise ModelError(f"{label}.D", "no D or c with a callable output (they belong to the affine output)", "a matrix")

    def validated(self, index: int, n: int, m: int, p: int, probe: tuple[np.ndarray, np.ndarray] | None = None) -> "Location":
        """A copy checked against ``(n, m, p)``; callables are evaluated once at ``probe = (x, u)``.

        Parameters
        ----------
        index : int
            Position of the location in the automaton (used in error messages).
        n, m, p : int
            Numbers of states, inputs and outputs of the automaton.
        probe : (x, u) pair of arrays, optional
            A point inside the invariant at which the callable flow / output are evaluated once to
            check their shape; ``None`` skips that check.

        Returns
        -------
        Location
            The checked copy.

        Raises
        ------
        ModelError
            If a matrix, the invariant's dimension or a callable's result has the wrong shape.
        """
        f = f"locations[{index}] ({self.name})"
        if self.invariant.dim not in (n, n + m):
            raise ModelError(f"{f}.invariant", f"a Polytope over x (dim {n}) or over (x, u) (dim {n + m})",
                             f"dimension {self.invariant.dim}")
        A = B = E = C = D = c = None
        at = "" if probe is None else f"x = {probe[0].tolist()}, u = {probe[1].tolist()} (inside the invariant)"
        if self.A is not None:
            A = as_matrix(self.A, f"{f}.A", (n, n))
            B = _input_matrix(self.B, f"{f}.B", n, m)
            E = as_vector(np.zeros(n) if self.E is None else self.E, f"{f}.E", n)
        elif probe is not None:
            probe_callable(self.flow, probe, f"{f}.flow", n, "flow(x, u) -> dx", at)
        if self.C is not None:
            C = as_matrix(self.C, f"{f}.C", (p, n))
            D = as_matrix(np.zeros((p, m)) if self.D is None or (self.D.size == 0 and p * m == 0) else self.D,
                          f"{f}.D", (p, m))
            c = as_vector(np.zeros(p) if self.c is None else self.c, f"{f}.c", p)
        elif probe is not None:
            probe_callable(self.output, probe, f"{f}.output", p, "output(x, u) -> y", at)
        return Location(self.name, self.invariant, A, B, E, C, D, c, self.flow, self.output)


    @classmethod
    def from_control(cls, name: str, sys: Any, invariant: Polytope, *, E: Sequence[float] | None = None,
                     c: Sequence[float] | None = None) -> "Location":
        """A location with the affine flow ``x' = A x + B u + E`` and output ``y = C x + D u + c`` of a python-control system.

        Parameters
        ----------
        name : str
            Name of the location.
        sys : control.StateSpace
            Continuous-time system (``dt=0``) holding ``A, B, C, D``; a discrete-time one is
            refused (field ``sys.dt``).
        invariant : Polytope
            Region of the state (or of ``(x, u)``) where the location is active.
        E : (n,) array_like, optional
            Affine term of the flow (default zeros; a ``StateSpace`` cannot hold it).
        c : (p,) array_like, optional
            Affine term of the output (default zeros).

        Returns
        -------
        Location
            The location; its shapes are checked when a :class:`HybridAutomaton` is built of it.

        Raises
        ------
        ModelError
            ``sys`` is not a continuous-time ``StateSpace``, or python-control is not installed
            (the ``interop`` extra).

        See Also
        --------
        Location.to_control : The way back.
        hybobs_opt.systems.pwa.PWAMode.from_control : A discrete-time mode.

        Examples
        --------
        >>> import control
        >>> from hybobs_opt import Location, Polytope
        >>> sys = control.ss([[0.0, 1.0], [-1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
        >>> loc = Location.from_control("centre", sys, Polytope.from_box([-5, -5], [5, 5]), E=[0.0, -0.5])
        >>> loc.A.tolist(), loc.E.tolist(), loc.is_affine
        ([[0.0, 1.0], [-1.0, 0.0]], [0.0, -0.5], True)
        """
        from .control_bridge import check_state_space

        A, B, C, D, _ = check_state_space(sys, "sys", discrete=False)
        return cls(name, invariant, A, B, np.zeros(A.shape[0]) if E is None else E, C, D,
                   np.zeros(C.shape[0]) if c is None else c)

    def to_control(self, *, drop_affine: bool = False, states: Sequence[str] = (), inputs: Sequence[str] = (),
                   outputs: Sequence[str] = ()) -> Any:
        """The linear part ``(A, B, C, D)`` of an affine location as a continuous-time python-control system.

        A ``StateSpace`` has no affine terms: a location with a non-zero ``E`` or ``c`` is
        refused unless ``drop_affine=True`` (then they stay on the location).  The invariant is
        not carried.

        Parameters
        ----------
        drop_affine : bool, default False
            Convert a location with non-zero affine terms by leaving them out.
        states, inputs, outputs : sequence of str, optional
            Signal names (python-control's ``x[0]``, ... when empty).

        Returns
        -------
        control.StateSpace
            Continuous-time system (``dt=0``) named after the location.

        Raises
        ------
        ModelError
            A callable flow or output (field ``flow`` / ``output``), a non-zero affine term without
            ``drop_affine``, a location without inputs (python-control 0.10 cannot hold one), or
            python-control is not installed.

        See Also
        --------
        Location.from_control : The way in.

        Examples
        --------
        >>> import numpy as np
        >>> from hybobs_opt import Location, Polytope
        >>> loc = Location("centre", Polytope.from_box([-5, -5], [5, 5]), A=np.array([[0.0, 1.0], [-1.0, 0.0]]),
        ...                B=np.array([[0.0], [1.0]]), C=np.array([[1.0, 0.0]]))
        >>> sys = loc.to_control()
        >>> sys.A.tolist(), sys.dt, sys.name
        ([[0.0, 1.0], [-1.0, 0.0]], 0, 'centre')
        """
        from .control_bridge import affine_or_refuse, make_state_space

        label = f"Location {self.name!r}"
        if self.A is None:
            raise ModelError(f"{label}.flow", "an affine flow (A, B, E) to convert", "a callable flow")
        if self.C is None:
            raise ModelError(f"{label}.output", "an affine output (C, D, c) to convert", "a callable output")
        affine_or_refuse([("E", self.E), ("c", self.c)], drop_affine, label)
        n, p = self.A.shape[0], self.C.shape[0]
        B = np.zeros((n, 0)) if self.B is None else self.B.reshape(n, -1)
        D = np.zeros((p, B.shape[1])) if self.D is None else self.D
        return make_state_space(self.A, B, self.C, D, 0, field=f"{label}.B", name=self.name, states=states,
                                inputs=inputs, outputs=outputs)


def _input_matrix(value, field: str, n: int, m: int) -> np.ndarray:
    """``B`` of shape ``(n, m)``; ``None`` means zeros, an empty array stands for "no inputs" only."""
    if value is None:
        return as_matrix(np.zeros((n, m)), field, (n, m))
    if np.size(value) == 0:
        if m > 0:
            raise ModelError(field, f"an (n, m) = ({n}, {m}) input matrix or None (the system has {m} input(s))",
                             f"an empty array of shape {np.shape(value)}")
        return as_matrix(np.zeros((n, 0)), field, (n, 0))
    return as_matrix(value, field, (n, m))


@dataclass(frozen=True, eq=False)
class Edge:
    """An allowed transition ``source -> target`` of the location graph.

    Parameters
    ----------
    source, target : int
        Location indices.
    guard : Polytope, optional
        Region of the state (dim ``n``) where the jump may be taken; ``None`` means "when the
        state enters the target's invariant".
    reset : (R, r), optional
        Affine reset ``x+ = R x + r`` applied at the jump (identity by default).

    See Also
    --------
    HybridAutomaton : its ``edges``.
    Location : the locations it joins.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.systems import Edge
    >>> edge = Edge(0, 1)                                       # any time the invariant is left
    >>> edge.source, edge.target, edge.guard, edge.reset
    (0, 1, None, None)
    >>> jump = Edge(1, 0, reset=(np.eye(1), np.array([0.5])))   # x := x + 0.5 on the way back
    >>> jump.reset[1]
    array([0.5])
    """

    source: int
    target: int
    guard: Polytope | None = None
    reset: tuple[np.ndarray, np.ndarray] | None = None

    def __post_init__(self) -> None:
        # Types only: the automaton checks the indices against its locations and the dimensions.
        for end in ("source", "target"):
            as_int(getattr(self, end), f"Edge.{end}", 0, "a location index (an integer >= 0)")
        if self.guard is not None and not isinstance(self.guard, Polytope):
            raise ModelError("Edge.guard", "a Polytope over x or None", type(self.guard).__name__)
        if self.reset is not None:
            if isinstance(self.reset, (str, bytes, np.ndarray)) or not isinstance(self.reset, (tuple, list)) or len(self.reset) != 2:
                raise ModelError("Edge.reset", "a pair (R, r) of the affine reset x+ = R x + r, or None", repr(self.reset)[:60])
            R = real_array(self.reset[0], "Edge.reset[0]", "a numeric matrix R")
            r = real_array(self.reset[1], "Edge.reset[1]", "a numeric vector r")
            object.__setattr__(self, "reset", (R, r))


@dataclass(frozen=True, eq=False)
class HybridAutomaton(ModelDictMixin):
    """A continuous-time hybrid automaton with polyhedral invariants.

    Parameters
    ----------
    locations : sequence of Location
    edges : sequence of Edge
        The allowed location graph; ``None`` means every pair of locations whose invariants touch.
    state_bounds : Polytope
        Bounded operating set ``X`` of the state (used for scaling and by :meth:`discretize`).
    input_bounds : Polytope or None
        Bounded input set ``U``; ``None`` for autonomous automata.
    state_names, input_names, output_names : sequence of str
    name : str
    p : int, optional
        Number of outputs; default: the rows of the first location's ``C`` (needed when no
        location has one).

    See Also
    --------
    Location, Edge : its parts.
    hybobs_opt.sim.simulate_hybrid : simulates it with event location.

    Examples
    --------
    Two locations split at ``x = 0``; from ``x = -1`` the flow ``x' = 1 - x`` reaches the switching
    surface at ``t = ln 2``:

    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import Edge, HybridAutomaton, Location
    >>> below = Location("below", Polytope(np.array([[1.0]]), np.array([0.0])),        # x <= 0
    ...                  A=np.array([[-1.0]]), E=np.array([1.0]), C=np.array([[1.0]]))  # x' = 1 - x
    >>> above = Location("above", Polytope(np.array([[-1.0]]), np.array([0.0])),       # x >= 0
    ...                  A=np.array([[-2.0]]), C=np.array([[1.0]]))                      # x' = -2 x
    >>> automaton = HybridAutomaton((below, above), Polytope.from_box([-5.0], [5.0]),
    ...                             edges=(Edge(0, 1), Edge(1, 0)), state_names=("x",))
    >>> automaton
    HybridAutomaton(name='automaton', n=1, m=0, p=1, locations=('below', 'above'))
    >>> from hybobs_opt.sim import simulate_hybrid
    >>> trace = simulate_hybrid(automaton, [-1.0], 2.0, dt=0.01)
    >>> [(round(event["t"], 4), event["from"], event["to"]) for event in trace.events]
    [(0.6931, 0, 1)]
    """

    locations: tuple[Location, ...]
    state_bounds: Polytope
    edges: tuple[Edge, ...] | None = None
    input_bounds: Polytope | None = None
    state_names: tuple[str, ...] = field(default=())
    input_names: tuple[str, ...] = field(default=())
    output_names: tuple[str, ...] = field(default=())
    name: str = "automaton"
    p: int | None = None

    def __post_init__(self) -> None:
        locs = as_items(self.locations, "locations", Location, "Location")
        if not locs:
            raise ModelError("locations", "at least one Location", "an empty sequence")
        if not isinstance(self.state_bounds, Polytope):
            raise ModelError("state_bounds", "a bounded Polytope over x", type(self.state_bounds).__name__)
        if self.input_bounds is not None and not isinstance(self.input_bounds, Polytope):
            raise ModelError("input_bounds", "a bounded Polytope over u, or None", type(self.input_bounds).__name__)
        as_text(self.name, "name")
        n = self.state_bounds.dim
        m = 0 if self.input_bounds is None else self.input_bounds.dim
        names = [loc.name for loc in locs]
        for i, nm in enumerate(names):
            if names.index(nm) != i:
                raise ModelError(f"locations[{i}].name", f"a name no other location has (locations[{names.index(nm)}] "
                                 f"is {nm!r} too; edges may name their locations)", repr(nm))
        edges = self.edges
        if edges is not None:
            edges = as_items(edges, "edges", Edge, "Edge")
        if not self.state_bounds.is_bounded():
            raise ModelError("state_bounds", "a bounded, non-empty polytope", "an unbounded or empty set")
        if self.input_bounds is not None and not self.input_bounds.is_bounded():
            raise ModelError("input_bounds", "a bounded, non-empty polytope", "an unbounded or empty set")
        lo, hi = self.state_bounds.bounding_box()
        scale = np.where(hi - lo > 0, hi - lo, 1.0)
        u_probe = np.zeros(0)
        if self.input_bounds is not None:
            ulo, uhi = self.input_bounds.bounding_box()
            u_probe = 0.5 * (ulo + uhi)
        # One point inside each location's invariant (the centre of its largest ball in X), where
        # callable flows and outputs are evaluated once; the same LP proves the invariant is
        # full-dimensional in X.
        probes = []
        for i, loc in enumerate(locs):
            f = f"locations[{i}] ({loc.name}).invariant"
            if loc.invariant.dim not in (n, n + m):
                raise ModelError(f, f"a Polytope over x (dim {n}) or over (x, u) (dim {n + m})",
                                 f"dimension {loc.invariant.dim}")
            if loc.invariant.dim == n:
                centre, radius = loc.invariant.intersect(self.state_bounds).chebyshev_ball(scale)
                if centre is None or not radius > FULL_DIMENSION_RTOL:
                    raise ModelError(f, "a full-dimensional region inside state_bounds", "an empty or lower-dimensional set")
                probes.append((centre + 0.0, u_probe + 0.0))
            elif loc.A is None or loc.C is None:
                domain = self.state_bounds if self.input_bounds is None else self.state_bounds.product(self.input_bounds)
                centre, _ = loc.invariant.intersect(domain).chebyshev_ball(np.concatenate([scale, np.ones(m)]))
                if centre is None:
                    raise ModelError(f, "a non-empty region inside state_bounds x input_bounds", "an empty set")
                probes.append((centre[:n] + 0.0, centre[n:] + 0.0))
            else:
                probes.append(None)
        p = self.p
        if p is not None:
            p = as_int(p, "p", 0, "the number of outputs (an integer >= 0) or None")
        else:
            first = next((i for i, loc in enumerate(locs) if loc.C is not None), None)
            if first is not None:
                C0 = locs[first].C
                if not (C0.ndim == 2 and C0.shape[1] == n) and not (C0.ndim == 1 and n == 1):
                    raise ModelError(f"locations[{first}] ({locs[first].name}).C",
                                     f"an output matrix of shape (p, n) with n = {n} columns", f"shape {C0.shape}")
                p = C0.shape[0]
            else:
                at = f"x = {probes[0][0].tolist()}, u = {probes[0][1].tolist()} (inside the invariant)"
                p = int(probe_callable(locs[0].output, probes[0], f"locations[0] ({locs[0].name}).output", None,
                                       "output(x, u) -> y", at).size)
        object.__setattr__(self, "p", int(p))
        locs = tuple(loc.validated(i, n, m, p, probes[i]) for i, loc in enumerate(locs))
        object.__setattr__(self, "locations", locs)
        state_names = as_names(_or_given(self.state_names, self.state_bounds), "state_names", n, "x")
        input_names = as_names(_or_given(self.input_names, self.input_bounds), "input_names", m, "u")
        object.__setattr__(self, "state_names", state_names)
        object.__setattr__(self, "input_names", input_names)
        object.__setattr__(self, "output_names", as_names(self.output_names, "output_names", p, "y"))
        check_coordinate_names(state_names, input_names,
                               [("state_bounds", self.state_bounds, False), ("input_bounds", self.input_bounds, True)]
                               + [(f"locations[{i}] ({loc.name}).invariant", loc.invariant, None) for i, loc in enumerate(locs)]
                               + [(f"edges[{k}].guard", e.guard, False) for k, e in enumerate(edges or ()) if e.guard is not None])
        if edges is None:
            edges = tuple(Edge(i, j) for i in range(len(locs)) for j in range(len(locs)) if i != j)
        checked = []
        for k, e in enumerate(edges):
            for end in ("source", "target"):
                v = getattr(e, end)
                if not 0 <= v < len(locs):
                    raise ModelError(f"edges[{k}].{end}", f"a location index in 0..{len(locs) - 1}", repr(v))
            if e.guard is not None and e.guard.dim != n:
                raise ModelError(f"edges[{k}].guard", f"a Polytope over x (dim {n}) or None", f"dimension {e.guard.dim}")
            reset = None
            if e.reset is not None:
                R, r = e.reset
                reset = (as_matrix(R, f"edges[{k}].reset[0]", (n, n)), as_vector(r, f"edges[{k}].reset[1]", n))
            checked.append(Edge(int(e.source), int(e.target), e.guard, reset))
        object.__setattr__(self, "edges", tuple(checked))

    # ------------------------------------------------------------------ dimensions
    @property
    def n(self) -> int:
        return self.state_bounds.dim

    @property
    def m(self) -> int:
        return 0 if self.input_bounds is None else self.input_bounds.dim

    @property
    def n_locations(self) -> int:
        return len(self.locations)

    @property
    def location_names(self) -> tuple[str, ...]:
        return tuple(loc.name for loc in self.locations)

    def successors(self, q: int) -> tuple[int, ...]:
        """Locations reachable from ``q`` by one edge of the location graph.

        Parameters
        ----------
        q : int
            0-based location index.

        Returns
        -------
        tuple of int
            The target locations of the edges leaving ``q``.
        """
        return tuple(e.target for e in self.edges if e.source == q)

    # ------------------------------------------------------------------ evaluation
    def _u(self, u) -> np.ndarray:
        if u is None:
            return np.zeros(self.m)
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if u.shape != (self.m,):
            raise ModelError("u", f"an input of length {self.m}", f"shape {u.shape}")
        return u

    def in_invariant(self, q: int, x, u=None, rtol: float | None = None) -> bool:
        """True when ``x`` (and ``u``) satisfy the invariant of location ``q``.

        Parameters
        ----------
        q : int
            0-based location index.
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input, used when the invariant is over ``(x, u)``; ``None`` means zeros.
        rtol : float, optional
            Relative tolerance of the membership test; ``None`` uses :meth:`Polytope.contains`'s default.

        Returns
        -------
        bool
            Whether ``(x, u)`` is in location ``q``'s invariant.
        """
        inv = self.locations[q].invariant
        z = np.asarray(x, dtype=float) if inv.dim == self.n else np.concatenate([np.asarray(x, dtype=float), self._u(u)])
        return bool(inv.contains(z) if rtol is None else inv.contains(z, rtol))

    def location_of(self, x, u=None) -> int:
        """First location whose invariant contains ``x`` (and ``u``); raises ``ModelError`` if none.

        Parameters
        ----------
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input (``None`` means zeros).

        Returns
        -------
        int
            0-based location index.
        """
        for q in range(self.n_locations):
            if self.in_invariant(q, x, u):
                return q
        raise ModelError("x", "a state inside some location's invariant", f"{np.asarray(x).tolist()}")

    def flow(self, q: int, x, u=None) -> np.ndarray:
        """Right-hand side ``dx/dt`` in location ``q``.

        Parameters
        ----------
        q : int
            0-based location index.
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input (``None`` means zeros).

        Returns
        -------
        (n,) ndarray
            ``A x + B u + E``, or ``flow(x, u)`` for a callable flow (checked finite).
        """
        loc = self.locations[q]
        u = self._u(u)
        x = np.asarray(x, dtype=float)
        if loc.A is not None:
            return loc.A @ x + loc.B @ u + loc.E
        dx = np.asarray(loc.flow(x, u), dtype=float).reshape(self.n)
        check_finite(dx, f"locations[{q}] ({loc.name}).flow(x, u)")
        return dx

    def output(self, q: int, x, u=None) -> np.ndarray:
        """Output ``y`` in location ``q``.

        Parameters
        ----------
        q : int
            0-based location index.
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input (``None`` means zeros).

        Returns
        -------
        (p,) ndarray
            ``C x + D u + c``, or ``output(x, u)`` for a callable output.
        """
        loc = self.locations[q]
        u = self._u(u)
        x = np.asarray(x, dtype=float)
        if loc.C is not None:
            return loc.C @ x + loc.D @ u + loc.c
        return np.asarray(loc.output(x, u), dtype=float).reshape(self.p)

    # ------------------------------------------------------------------ discretisation
    def discretize(self, Ts: float) -> PWASystem:
        """Exact zero-order-hold discretisation per location, giving a :class:`PWASystem`.

        For each location, ``[A_d, B_d, a_d] = [I, 0, 0] expm([[A, B, E], [0, 0, 0]] Ts)``, i.e.
        ``A_d = e^{A Ts}``, ``B_d = int_0^Ts e^{A s} ds B``, ``a_d = int_0^Ts e^{A s} ds E``; the
        guard of the resulting mode is the location's invariant (lifted to ``(x, u)``).  The
        location is frozen over a sample, as in the PWA models of paper 002: the map is exact for
        every sample whose trajectory does not cross a location boundary.

        Parameters
        ----------
        Ts : float
            Sampling period (positive, in the automaton's time unit).

        Returns
        -------
        PWASystem
            One mode per location, exact for inputs held over each sample period.

        Raises
        ------
        ModelError
            If ``Ts`` is not positive, or a location has a nonlinear flow or output.
        """
        if not (np.isfinite(Ts) and Ts > 0):
            raise ModelError("Ts", "a positive finite sampling period", repr(Ts))
        n, m = self.n, self.m
        modes = []
        for i, loc in enumerate(self.locations):
            if not loc.is_affine:
                raise ModelError(
                    f"locations[{i}] ({loc.name})", "an affine flow and output for discretize()", "a callable flow or output"
                )
            M = np.zeros((n + m + 1, n + m + 1))
            M[:n, :n] = loc.A
            M[:n, n : n + m] = loc.B
            M[:n, n + m] = loc.E
            Phi = expm(M * Ts)
            guard = loc.invariant if loc.invariant.dim == n + m else (
                loc.invariant if m == 0 else loc.invariant.lift(n + m, range(n))
            )
            modes.append(PWAMode(Phi[:n, :n], Phi[:n, n : n + m], Phi[:n, n + m], loc.C, guard, loc.D, loc.c, loc.name))
        return PWASystem(
            tuple(modes),
            self.state_bounds,
            self.input_bounds,
            self.state_names,
            self.input_names,
            self.output_names,
            Ts=float(Ts),
            name=f"{self.name} (ZOH, Ts={Ts:g})",
        )

    def __repr__(self) -> str:
        return f"HybridAutomaton(name={self.name!r}, n={self.n}, m={self.m}, p={self.p}, locations={self.location_names})"
