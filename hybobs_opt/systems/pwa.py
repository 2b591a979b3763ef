"""Discrete-time piecewise-affine systems, eq. (1) of paper 002.

``x(t+1) = A_i x(t) + B_i u(t) + a_i``, ``y(t) = C_i x(t) + D_i u(t) + c_i`` if
``[x(t); u(t)]`` lies in the guard polytope ``Q_i``, with bounded state and input sets
(eq. 2: ``X`` and ``U``).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ModelError
from ..geometry._reproducible import matmul as mm
from ..tolerances import FULL_DIMENSION_RTOL, MEMBERSHIP_RTOL, PARTITION_INTERIOR_MARGIN
from ._model_io import ModelDictMixin
from .._validate import as_int, as_items, as_matrix, as_names, as_real, as_text, as_vector, name_key, real_array
from ..geometry.polytope import Polytope


@dataclass(frozen=True, eq=False)
class PWAMode:
    """One affine piece of a PWA system (one index ``i`` of eq. (1), paper 002).

    Parameters
    ----------
    A : (n, n) array
    B : (n, m) array
    a : (n,) array
    C : (p, n) array
    D : (p, m) array, optional (zeros)
    c : (p,) array, optional (zeros)
    guard : Polytope
        ``Q_i`` over the stacked vector ``(x, u)`` of dimension ``n + m``.
    name : str
        Human-readable label (``"contact+"``, ``"backlash"``, ...).

    See Also
    --------
    PWASystem : the system of several modes.

    Examples
    --------
    One affine piece ``x+ = 0.5 x + u, y = x`` on the guard ``x <= 0`` (over ``(x, u)``):

    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode
    >>> mode = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")
    >>> mode.name, mode.A.shape, mode.guard.dim
    ('left', (1, 1), 2)
    """

    A: np.ndarray
    B: np.ndarray
    a: np.ndarray
    C: np.ndarray
    guard: Polytope
    D: np.ndarray | None = None
    c: np.ndarray | None = None
    name: str = ""

    def __post_init__(self) -> None:
        # Types only: the shapes are checked against the system's (n, m, p) by validated().
        label = "PWAMode" + (f" {self.name!r}" if isinstance(self.name, str) and self.name else "")
        as_text(self.name, f"{label}.name", allow_empty=True)
        for key in ("A", "B", "a", "C", "D", "c"):
            value = getattr(self, key)
            if value is None and key in ("B", "D", "c"):
                continue
            arr = real_array(value, f"{label}.{key}", "a numeric matrix" if key.isupper() else "a numeric vector")
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        if not isinstance(self.guard, Polytope):
            raise ModelError(f"{label}.guard", "a Polytope over (x, u)", type(self.guard).__name__)

    def validated(self, index: int, n: int, m: int, p: int) -> "PWAMode":
        """Return a copy whose arrays are checked against ``(n, m, p)``; fields named ``modes[index].X``.

        Parameters
        ----------
        index : int
            Position of the mode in the system (used in the field names of errors).
        n, m, p : int
            Numbers of states, inputs and outputs of the system.

        Returns
        -------
        PWAMode
            The checked copy.

        Raises
        ------
        ModelError
            If a matrix or the guard's dimension does not fit ``(n, m, p)``, or ``B`` is missing while
            ``m > 0``.
        """
        f = f"modes[{index}]"
        A = as_matrix(self.A, f"{f}.A", (n, n))
        if self.B is None or self.B.size == 0:
            # An empty B stands for "no inputs" only; with inputs it is a missing matrix, not zeros.
            if m > 0:
                raise ModelError(f"{f}.B", f"an (n, m) = ({n}, {m}) input matrix (the system has {m} input(s))",
                                 "None" if self.B is None else f"an empty array of shape {self.B.shape}")
            B = as_matrix(np.zeros((n, 0)), f"{f}.B", (n, 0))
        else:
            B = as_matrix(self.B, f"{f}.B", (n, m))
        a = as_vector(self.a, f"{f}.a", n)
        C = as_matrix(self.C, f"{f}.C", (p, n))
        D = as_matrix(np.zeros((p, m)) if self.D is None else self.D, f"{f}.D", (p, m))
        c = as_vector(np.zeros(p) if self.c is None else self.c, f"{f}.c", p)
        if self.guard.dim != n + m:
            raise ModelError(f"{f}.guard", f"a polytope of dimension n + m = {n + m}", f"dimension {self.guard.dim}")
        return PWAMode(A, B, a, C, self.guard, D, c, self.name or f"mode{index}")

    @classmethod
    def from_control(cls, sys: Any, guard: Polytope, *, a: Sequence[float] | None = None,
                     c: Sequence[float] | None = None, name: str | None = None) -> "PWAMode":
        """The mode ``x+ = A x + B u + a``, ``y = C x + D u + c`` on ``guard`` from a python-control system.

        Parameters
        ----------
        sys : control.StateSpace
            Discrete-time system (``dt > 0`` or ``dt=True``) holding ``A, B, C, D``.  A
            continuous-time one is refused: discretise it first (``control.c2d(sys, Ts, "zoh")``).
        guard : Polytope
            ``Q_i`` over the stacked vector ``(x, u)``.
        a : (n,) array_like, optional
            Affine term of the state update (default zeros; a ``StateSpace`` cannot hold it).
        c : (p,) array_like, optional
            Affine term of the output (default zeros).
        name : str, optional
            Label of the mode; default: the ss object's name when the user gave one, else ``""``.

        Returns
        -------
        PWAMode
            The mode; its shapes are checked against the system's when a :class:`PWASystem` is
            built of it.

        Raises
        ------
        ModelError
            ``sys`` is not a ``StateSpace``, is continuous-time (field ``sys.dt``), or python-control
            is not installed (the ``interop`` extra).

        See Also
        --------
        PWAMode.to_control : The way back (linear part only).
        PWASystem.from_control : A whole PWA system from one ss object per mode.

        Examples
        --------
        >>> import control
        >>> from hybobs_opt import PWAMode, Polytope
        >>> sys = control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], True, name="left")
        >>> mode = PWAMode.from_control(sys, Polytope.from_box([-1, -1], [0, 1]), a=[0.1])
        >>> mode.name, mode.A.tolist(), mode.a.tolist()
        ('left', [[0.5]], [0.1])
        """
        from .control_bridge import check_state_space, given_name

        A, B, C, D, _ = check_state_space(sys, "sys", discrete=True)
        n, p = A.shape[0], C.shape[0]
        a = np.zeros(n) if a is None else a
        c = np.zeros(p) if c is None else c
        return cls(A, B, a, C, guard, D, c, given_name(sys) if name is None else name)

    def to_control(self, dt: float | bool = True, *, drop_affine: bool = False, states: Sequence[str] = (),
                   inputs: Sequence[str] = (), outputs: Sequence[str] = ()) -> Any:
        """The linear part ``(A, B, C, D)`` of the mode as a discrete-time python-control system.

        A ``StateSpace`` has no affine terms: a mode with a non-zero ``a`` or ``c`` is refused
        unless ``drop_affine=True``, and then the returned system is only the linear part (the
        terms stay on the mode: ``mode.a``, ``mode.c``).  The guard is not carried either.

        Parameters
        ----------
        dt : float or True, default True
            Sampling period of the ss object (``True``: discrete, unspecified period).
        drop_affine : bool, default False
            Convert a mode with non-zero affine terms by leaving them out.
        states, inputs, outputs : sequence of str, optional
            Signal names (python-control's ``x[0]``, ... when empty).

        Returns
        -------
        control.StateSpace
            Discrete-time system named after the mode.

        Raises
        ------
        ModelError
            Non-zero affine terms without ``drop_affine`` (field ``a`` or ``c``), a mode without
            inputs (python-control 0.10 cannot hold one), or python-control is not installed.

        See Also
        --------
        PWAMode.from_control : The way in.
        PWASystem.to_control : Every mode of a system, with its names and sampling time.

        Examples
        --------
        >>> import numpy as np
        >>> from hybobs_opt import PWAMode, Polytope
        >>> mode = PWAMode(np.array([[0.5]]), np.array([[1.0]]), np.zeros(1), np.array([[1.0]]),
        ...                Polytope.from_box([-1, -1], [0, 1]), name="left")
        >>> sys = mode.to_control(0.1)
        >>> sys.A.tolist(), sys.dt, sys.name
        ([[0.5]], 0.1, 'left')
        """
        from .control_bridge import affine_or_refuse, make_state_space

        affine_or_refuse([("a", self.a), ("c", self.c)], drop_affine, f"mode {self.name!r}" if self.name else "mode")
        n, p = self.A.shape[0], self.C.shape[0]
        B = np.zeros((n, 0)) if self.B is None else self.B
        D = np.zeros((p, B.shape[1])) if self.D is None else self.D
        return make_state_space(self.A, B, self.C, D, _control_dt(dt), field="mode.B", name=self.name,
                                states=states, inputs=inputs, outputs=outputs)


#: Values of ``PWASystem.partition``.
PARTITION_CHECKS = ("check", "ordered", "none")


@dataclass(frozen=True, eq=False)
class PWASystem(ModelDictMixin):
    """Discrete-time PWA system of eq. (1), paper 002, with bounded state and input sets.

    Parameters
    ----------
    modes : sequence of PWAMode
        The affine pieces; their guards are intersected with ``X x U`` and must be
        full-dimensional there (paper 002: "disjoint, full dimensional ... polytopes").
    state_bounds : Polytope
        Bounded state set ``X`` (dimension ``n``).
    input_bounds : Polytope or None
        Bounded input set ``U`` (dimension ``m``); ``None`` only for autonomous systems (``m = 0``).
    state_names, input_names, output_names : sequence of str
        Names used in CLI options, plots and CSV headers.
    Ts : float, optional
        Sampling period in seconds (for time axes); ``None`` means unit steps.
    name : str
        Label of the system.
    partition : {"check", "ordered", "none"}
        What construction proves about the guards (:func:`check_partition`, LP tests):
        ``"check"`` (default): their union covers ``X x U`` and no two overlap (share interior);
        ``"ordered"``: they cover ``X x U``, overlaps are allowed and resolved by mode order;
        ``"none"``: no check (a point outside every guard raises in :meth:`mode_of`).

    See Also
    --------
    PWAMode : one mode.
    check_partition : proves the guards partition ``X x U``.
    hybobs_opt.sim.simulate_pwa : simulates it.
    hybobs_opt.regions.analyse_observability : Algorithm 3.1 on it.

    Notes
    -----
    Where guards share only a boundary (the "not necessarily closed" sets of eq. (1)), the first
    mode that contains the point wins; with ``partition="ordered"`` the same rule resolves
    overlaps.

    Examples
    --------
    A scalar system with two modes split at ``x = 0``:

    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> left = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")    # x <= 0
    >>> right = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...                 guard=Polytope(np.array([[-1.0, 0.0]]), np.array([0.0])), name="right")  # x >= 0
    >>> system = PWASystem((left, right), Polytope.from_box([-2.0], [2.0]), Polytope.from_box([-1.0], [1.0]),
    ...                    state_names=("x",), input_names=("u",), output_names=("y",))
    >>> system
    PWASystem(name='pwa', n=1, m=1, p=1, modes=2)
    >>> system.mode_of(np.array([1.0]), np.array([0.0]))     # x = 1 is in mode 1 ("right")
    1
    >>> system.step(np.array([1.0]), np.array([0.5]))         # 0.9 * 1 + 0.5
    array([1.4])

    The shipped examples are built the same way (model (16) of paper 002):

    >>> from hybobs_opt import get_example
    >>> get_example("powertrain3").build()
    PWASystem(name='powertrain3 (tau=0.08333)', n=3, m=1, p=1, modes=3)
    """

    modes: tuple[PWAMode, ...]
    state_bounds: Polytope
    input_bounds: Polytope | None = None
    state_names: tuple[str, ...] = field(default=())
    input_names: tuple[str, ...] = field(default=())
    output_names: tuple[str, ...] = field(default=())
    Ts: float | None = None
    name: str = "pwa"
    partition: str = "check"

    def __post_init__(self) -> None:
        modes = as_items(self.modes, "modes", PWAMode, "PWAMode")
        if not modes:
            raise ModelError("modes", "at least one PWAMode", "an empty sequence")
        if not isinstance(self.state_bounds, Polytope):
            raise ModelError("state_bounds", "a bounded Polytope over x", type(self.state_bounds).__name__)
        n = self.state_bounds.dim
        if self.input_bounds is None:
            m = 0
        elif isinstance(self.input_bounds, Polytope):
            m = self.input_bounds.dim
        else:
            raise ModelError("input_bounds", "a bounded Polytope over u, or None", type(self.input_bounds).__name__)
        as_text(self.name, "name")
        if not isinstance(self.partition, str) or self.partition not in PARTITION_CHECKS:
            raise ModelError("partition", f"one of {list(PARTITION_CHECKS)}", repr(self.partition))
        # The number of outputs is read from the first mode's C, once it is known to be a matrix
        # with n columns (PWAMode already made it a real array).
        C0 = modes[0].C
        if C0.ndim == 2 and C0.shape[1] == n:
            p = C0.shape[0]
        elif C0.ndim == 1 and n == 1:
            p = C0.shape[0]
        else:
            raise ModelError("modes[0].C", f"an output matrix of shape (p, n) with n = {n} columns", _shape(C0))
        modes = tuple(mode.validated(i, n, m, p) for i, mode in enumerate(modes))
        object.__setattr__(self, "modes", modes)
        state_names = as_names(_or_given(self.state_names, self.state_bounds), "state_names", n, "x")
        input_names = as_names(_or_given(self.input_names, self.input_bounds), "input_names", m, "u")
        object.__setattr__(self, "state_names", state_names)
        object.__setattr__(self, "input_names", input_names)
        object.__setattr__(self, "output_names", as_names(self.output_names, "output_names", p, "y"))
        check_coordinate_names(state_names, input_names, [("state_bounds", self.state_bounds, False),
                                                          ("input_bounds", self.input_bounds, True)]
                               + [(f"modes[{i}].guard", mode.guard, None) for i, mode in enumerate(modes)])
        if self.Ts is not None:
            Ts = as_real(self.Ts, "Ts", "a positive finite sampling period or None")
            if not (np.isfinite(Ts) and Ts > 0):
                raise ModelError("Ts", "a positive finite sampling period or None", repr(self.Ts))
        for label, poly in (("state_bounds", self.state_bounds), ("input_bounds", self.input_bounds)):
            if poly is not None and not poly.is_bounded():
                raise ModelError(label, "a bounded, non-empty polytope (every coordinate bounded)", "an unbounded or empty set")
        domain = self.domain
        lo, hi = domain.bounding_box()
        scale = np.where(hi - lo > 0, hi - lo, 1.0)
        half, centre = np.where(hi - lo > 0, (hi - lo) / 2.0, 1.0), (hi + lo) / 2.0
        half.setflags(write=False)
        centre.setflags(write=False)
        object.__setattr__(self, "_scales", (half, centre))
        object.__setattr__(self, "_domain", domain)
        # Mode lookup table: every mode's guard rows followed by the domain rows, stacked, so
        # that modes_of is one matrix product and a segmented max (used in runtime loops).
        rows = [np.vstack([mode.guard.A, domain.A]) for mode in modes]
        rhs = [np.concatenate([mode.guard.b, domain.b]) for mode in modes]
        starts = np.cumsum([0] + [r.shape[0] for r in rows[:-1]])
        table_b = np.concatenate(rhs)
        object.__setattr__(self, "_mode_table", (np.vstack(rows), table_b + MEMBERSHIP_RTOL * (1.0 + np.abs(table_b)), starts))
        for i, mode in enumerate(modes):
            if not mode.guard.intersect(domain).is_full_dimensional(scale):
                raise ModelError(
                    f"modes[{i}].guard",
                    "a full-dimensional polytope inside X x U (paper 002, eq. 1)",
                    "an empty or lower-dimensional set",
                )
        if self.partition != "none":
            check_partition(self, overlaps=self.partition == "check")

    # ------------------------------------------------------------------ dimensions
    @property
    def n(self) -> int:
        """Number of states."""
        return self.state_bounds.dim

    @property
    def m(self) -> int:
        """Number of inputs."""
        return 0 if self.input_bounds is None else self.input_bounds.dim

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.modes[0].C.shape[0]

    @property
    def n_modes(self) -> int:
        return len(self.modes)

    @property
    def domain(self) -> Polytope:
        """``X x U`` as one polytope over ``(x, u)``."""
        cached = self.__dict__.get("_domain")
        if cached is not None:
            return cached
        if self.input_bounds is None:
            return self.state_bounds
        return self.state_bounds.product(self.input_bounds)

    # ------------------------------------------------------------------ evaluation
    def _xu(self, x, u) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        u = np.zeros(x.shape[:-1] + (0,)) if u is None else np.asarray(u, dtype=float)
        if x.shape[-1] != self.n:
            raise ModelError("x", f"a state of length {self.n}", f"shape {x.shape}")
        if u.ndim == 0:
            u = u.reshape(1)
        if u.shape[-1] != self.m:
            raise ModelError("u", f"an input of length {self.m}", f"shape {u.shape}")
        return np.concatenate([x, u], axis=-1)

    def modes_of(self, X: np.ndarray, U: np.ndarray | None = None) -> np.ndarray:
        """Vectorised mode lookup: index of the first guard containing each row of ``[X U]``, ``-1`` if none.

        Parameters
        ----------
        X : (N, n) array_like
            States, one per row (a single ``(n,)`` state is one row).
        U : (N, m) array_like, optional
            Inputs, one per row; ``None`` for a system without inputs.

        Returns
        -------
        (N,) int ndarray
            0-based mode index of each row, ``-1`` outside every guard.
        """
        Z = self._xu(np.atleast_2d(X), None if U is None else np.atleast_2d(U))
        table, rhs, starts = self._mode_table
        inside = np.maximum.reduceat(mm(Z, table.T) - rhs, starts, axis=1) <= 0.0
        return np.where(inside.any(axis=1), np.argmax(inside, axis=1), -1)

    def mode_of(self, x: Sequence[float], u: Sequence[float] | None = None) -> int:
        """Index of the mode whose guard contains ``(x, u)``.

        Parameters
        ----------
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input; ``None`` for a system without inputs.

        Returns
        -------
        int
            The index into ``modes``.

        Raises
        ------
        ModelError
            If ``(x, u)`` lies outside ``X x U`` or outside every guard.
        """
        i = int(self.modes_of(np.asarray(x, dtype=float)[None, :], None if u is None else np.atleast_1d(u)[None, :])[0])
        if i < 0:
            raise ModelError("(x, u)", "a point of X x U inside one of the guards", f"x={np.asarray(x).tolist()}, u={None if u is None else np.atleast_1d(u).tolist()}")
        return i

    def step(self, x, u=None) -> np.ndarray:
        """Successor state ``A_i x + B_i u + a_i`` with ``i = mode_of(x, u)`` (eq. 1).

        Parameters
        ----------
        x : (n,) array_like
            State at sample ``k``.
        u : (m,) array_like, optional
            Input at sample ``k``; ``None`` for a system without inputs.

        Returns
        -------
        (n,) ndarray
            ``x(k+1)``.
        """
        i = self.mode_of(x, u)
        mode = self.modes[i]
        uu = np.zeros(0) if u is None else np.atleast_1d(np.asarray(u, dtype=float))
        return mm(mode.A, np.asarray(x, dtype=float)) + mm(mode.B, uu) + mode.a

    def output(self, x, u=None) -> np.ndarray:
        """Output ``C_i x + D_i u + c_i`` with ``i = mode_of(x, u)`` (eq. 1).

        Parameters
        ----------
        x : (n,) array_like
            State.
        u : (m,) array_like, optional
            Input; ``None`` for a system without inputs.

        Returns
        -------
        (p,) ndarray
            ``y(k)``.
        """
        i = self.mode_of(x, u)
        mode = self.modes[i]
        uu = np.zeros(0) if u is None else np.atleast_1d(np.asarray(u, dtype=float))
        return mm(mode.C, np.asarray(x, dtype=float)) + mm(mode.D, uu) + mode.c

    def scales(self) -> tuple[np.ndarray, np.ndarray]:
        """Half-widths and centres of the bounding box of ``X x U``: the normalisation of DESIGN.md.

        Computed once at construction (read-only arrays).

        Returns
        -------
        scale, centre : (n + m,) ndarray
            ``z = centre + scale * w`` maps ``w in [-1, 1]`` onto the box.
        """
        return self._scales

    # ------------------------------------------------------------------ python-control
    @classmethod
    def from_control(cls, systems: Sequence[Any], guards: Sequence[Polytope], state_bounds: Polytope,
                     input_bounds: Polytope | None = None, *, affine: Sequence[Sequence[float] | None] | None = None,
                     output_affine: Sequence[Sequence[float] | None] | None = None,
                     mode_names: Sequence[str] | None = None, state_names: Sequence[str] | None = None,
                     input_names: Sequence[str] | None = None, output_names: Sequence[str] | None = None,
                     name: str = "pwa", partition: str = "check") -> "PWASystem":
        """A PWA system (eq. 1, paper 002) with one python-control system per mode.

        Parameters
        ----------
        systems : sequence of control.StateSpace
            Discrete-time systems (``dt > 0`` or ``dt=True``), one per mode; numeric sampling
            periods must agree and become ``Ts`` (``None`` when every ``dt`` is ``True``).
        guards : sequence of Polytope
            The guard ``Q_i`` over ``(x, u)`` of each mode.
        state_bounds : Polytope
            Bounded state set ``X``.
        input_bounds : Polytope or None, optional
            Bounded input set ``U``.
        affine : sequence of (n,) array_like or None, optional
            The affine terms ``a_i`` of the state update, one per mode (``None`` entries: zeros).
        output_affine : sequence of (p,) array_like or None, optional
            The affine terms ``c_i`` of the output, one per mode.
        mode_names : sequence of str, optional
            Labels of the modes; default: the ss objects' names where the user gave them.
        state_names, input_names, output_names : sequence of str, optional
            Signal names; default: the ss objects' labels when the user gave them (they must then
            agree between the modes), else ``x1, ...``, ``u1, ...``, ``y1, ...``.
        name : str, default "pwa"
            Label of the system.
        partition : {"check", "ordered", "none"}, default "check"
            What construction proves about the guards (see :class:`PWASystem`).

        Returns
        -------
        PWASystem
            The validated system.

        Raises
        ------
        ModelError
            A system is not a discrete-time ``StateSpace``, the sampling periods or given labels
            disagree, a list has the wrong length, the usual checks of :class:`PWASystem` fail,
            or python-control is not installed (the ``interop`` extra).

        See Also
        --------
        PWAMode.from_control : One mode.
        PWASystem.to_control : The way back.

        Examples
        --------
        >>> import control
        >>> from hybobs_opt import PWASystem, Polytope
        >>> left = control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1, states=["x"], inputs=["u"], outputs=["y"])
        >>> right = control.ss([[0.8]], [[1.0]], [[1.0]], [[0.0]], 0.1, states=["x"], inputs=["u"], outputs=["y"])
        >>> pwa = PWASystem.from_control([left, right],
        ...                              [Polytope.from_box([-1, -1], [0, 1]), Polytope.from_box([0, -1], [1, 1])],
        ...                              Polytope.from_box([-1], [1]), Polytope.from_box([-1], [1]),
        ...                              affine=[[0.1], None])
        >>> pwa.n_modes, pwa.Ts, pwa.state_names, pwa.modes[0].a.tolist()
        (2, 0.1, ('x',), [0.1])
        """
        from .control_bridge import check_state_space, given_labels, given_name, sampling_time

        systems = list(as_items(systems, "systems", object, "a control.StateSpace"))
        guards = list(as_items(guards, "guards", Polytope, "a Polytope over (x, u)"))
        if len(guards) != len(systems):
            raise ModelError("guards", f"one guard per system ({len(systems)})", f"{len(guards)}")
        per_mode = {}
        for key, values in (("affine", affine), ("output_affine", output_affine), ("mode_names", mode_names)):
            if values is None:
                values = [None] * len(systems)
            elif isinstance(values, (str, bytes)) or len(values) != len(systems):
                raise ModelError(key, f"one entry per system ({len(systems)})",
                                 repr(values) if isinstance(values, (str, bytes)) else f"{len(values)}")
            per_mode[key] = list(values)
        dts, modes = [], []
        for i, sys in enumerate(systems):
            check_state_space(sys, f"systems[{i}]", discrete=True)
            dts.append(sys.dt)
            mode_name = per_mode["mode_names"][i]
            modes.append(PWAMode.from_control(sys, guards[i], a=per_mode["affine"][i], c=per_mode["output_affine"][i],
                                              name=mode_name if mode_name is not None else None))
        Ts = sampling_time(dts, "systems[*].dt")
        names = {}
        for key, attr, given in (("state_names", "state_labels", state_names), ("input_names", "input_labels", input_names),
                                 ("output_names", "output_labels", output_names)):
            if given is not None:
                names[key] = given
                continue
            labels = {given_labels(getattr(sys, attr)) for sys in systems} - {()}
            if len(labels) > 1:
                raise ModelError(key, f"the same {attr} on every system (or {key}=...)", f"{sorted(labels)}")
            names[key] = labels.pop() if labels else ()
        return cls(tuple(modes), state_bounds, input_bounds, names["state_names"], names["input_names"],
                   names["output_names"], Ts, name, partition)

    def to_control(self, *, drop_affine: bool = False) -> list[Any]:
        """Each mode's linear part as a discrete-time python-control system (``dt = Ts``, or ``True``).

        A ``StateSpace`` has neither affine terms nor a guard: the guards stay on the system
        (``modes[i].guard``), and a system with a non-zero affine term ``a_i`` or ``c_i`` is
        refused unless ``drop_affine=True``; then the list holds the linear parts only and the
        terms are ``modes[i].a`` and ``modes[i].c``.

        Parameters
        ----------
        drop_affine : bool, default False
            Convert the linear parts of modes with non-zero affine terms.

        Returns
        -------
        list of control.StateSpace
            One per mode, named after the mode, with the system's state, input and output names.

        Raises
        ------
        ModelError
            A non-zero affine term without ``drop_affine`` (field ``modes[i].a`` / ``.c``), a system
            without inputs (python-control 0.10 cannot hold one), or python-control is not installed.

        See Also
        --------
        PWASystem.from_control : The way back.
        PWAMode.to_control : One mode.

        Examples
        --------
        >>> import numpy as np
        >>> from hybobs_opt import PWAMode, PWASystem, Polytope
        >>> modes = [PWAMode(np.array([[0.5]]), np.array([[1.0]]), np.zeros(1), np.array([[1.0]]),
        ...                  Polytope.from_box([-1, -1], [0, 1]), name="left"),
        ...          PWAMode(np.array([[0.8]]), np.array([[1.0]]), np.array([0.1]), np.array([[1.0]]),
        ...                  Polytope.from_box([0, -1], [1, 1]), name="right")]
        >>> pwa = PWASystem(modes, Polytope.from_box([-1], [1]), Polytope.from_box([-1], [1]), Ts=0.1)
        >>> [(s.name, s.A.tolist(), s.dt) for s in pwa.to_control(drop_affine=True)]
        [('left', [[0.5]], 0.1), ('right', [[0.8]], 0.1)]
        """
        from .control_bridge import affine_or_refuse

        for i, mode in enumerate(self.modes):
            affine_or_refuse([("a", mode.a), ("c", mode.c)], drop_affine, f"modes[{i}]")
        dt = True if self.Ts is None else float(self.Ts)
        return [mode.to_control(dt, drop_affine=True, states=self.state_names, inputs=self.input_names,
                                outputs=self.output_names) for mode in self.modes]

    def __repr__(self) -> str:
        return f"PWASystem(name={self.name!r}, n={self.n}, m={self.m}, p={self.p}, modes={self.n_modes})"


def _control_dt(dt) -> float | bool:
    """``dt`` of a python-control discrete-time system: ``True`` or a positive finite period."""
    if dt is True:
        return True
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) or not (np.isfinite(dt) and dt > 0):
        raise ModelError("dt", "True or a positive finite sampling period", repr(dt))
    return float(dt)


def _shape(arr: np.ndarray) -> str:
    return f"shape {arr.shape}"


def _given_names(poly: Polytope | None) -> tuple[str, ...]:
    """The coordinate names of a set when they were given (not the default labels ``z1, z2, ...``)."""
    if poly is None or poly.names == tuple(f"z{i + 1}" for i in range(poly.dim)):
        return ()
    return poly.names


def _or_given(names, poly: Polytope | None):
    """``names``, or the given coordinate names of ``poly`` when ``names`` is ``None`` or an empty list."""
    if names is None or (isinstance(names, (list, tuple, np.ndarray)) and len(names) == 0):
        return _given_names(poly)
    return names


def check_coordinate_names(state_names: tuple[str, ...], input_names: tuple[str, ...], sets) -> None:
    """Refuse a set whose given coordinate names are not the system's names of its space.

    ``sets`` holds ``(field, polytope, over_inputs)``: ``over_inputs`` False means a set over x,
    True over u, None over x or (x, u) (by its dimension).  Default labels (``z1, z2, ...``, what
    ``Polytope.from_box`` gives without names) say nothing and are accepted.  States and inputs
    share the space of the guards, so a name may not be both.
    """
    states = {name_key(nm): nm for nm in state_names}
    both = sorted(nm for nm in input_names if name_key(nm) in states)
    if both:
        raise ModelError("input_names", f"names distinct from the state names {list(state_names)} (compared after NFKC "
                         "normalisation)", f"{both[0]!r} in both" if both[0] in state_names
                         else f"{both[0]!r} and the state {states[name_key(both[0])]!r}")
    for label, poly, over_inputs in sets:
        given = _given_names(poly)
        if not given:
            continue
        if over_inputs is True:
            want = input_names
        elif over_inputs is False or poly.dim == len(state_names):
            want = state_names
        else:
            want = state_names + input_names
        if given != want:
            raise ModelError(f"{label}.names", f"the system's coordinate names {list(want)} (or no names)", f"{list(given)}")


#: Outcomes of :func:`check_partition` by the digest of everything it reads (guards, domain,
#: names), most recent last: a study builds the same system many times, and each check costs a
#: Chebyshev-ball LP per pair of guards plus the polytope differences.
_PARTITION_OUTCOMES: OrderedDict[bytes, tuple | None] = OrderedDict()
_PARTITION_OUTCOMES_MAX = 256


def _partition_key(system: PWASystem, overlaps: bool) -> bytes:
    h = hashlib.sha256(b"overlaps" if overlaps else b"cover")
    polys = [system.domain] + [mode.guard for mode in system.modes]
    for P in polys:
        for arr in (P.A, P.b):
            a = np.ascontiguousarray(arr, dtype=float)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
    names = [mode.name for mode in system.modes] + list(system.state_names) + list(system.input_names)
    h.update("\x00".join(names).encode("utf-8", "surrogatepass"))
    return h.digest()


def check_partition(system: PWASystem, overlaps: bool = True) -> None:
    """Prove that the guards of ``system`` cover ``X x U`` and (``overlaps=True``) do not overlap.

    Every pair of guards is tested for a common interior (a Chebyshev-ball LP on
    ``Q_i ∩ Q_j ∩ (X x U)``), and ``X x U`` minus the guards, one after the other
    (:func:`~hybobs_opt.geometry.difference.polytope_difference`), must leave no
    full-dimensional piece.  Sets thinner than
    :data:`~hybobs_opt.tolerances.FULL_DIMENSION_RTOL` (relative to ``X x U``) are ignored: a
    shared boundary is not an overlap.

    Parameters
    ----------
    system : PWASystem
        The system whose guards are checked.
    overlaps : bool, default True
        Also check that no two guards share an interior; ``False`` checks the covering only.

    Raises
    ------
    ModelError
        Naming the two modes that overlap, or the gap, with a point inside it (``x``, ``u`` by name).

    See Also
    --------
    PWASystem : the system whose guards it checks.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> left = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")    # x <= 0
    >>> right = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...                 guard=Polytope(np.array([[-1.0, 0.0]]), np.array([0.0])), name="right")  # x >= 0
    >>> system = PWASystem((left, right), Polytope.from_box([-2.0], [2.0]), Polytope.from_box([-1.0], [1.0]),
    ...                    state_names=("x",), input_names=("u",), output_names=("y",))
    >>> from hybobs_opt.systems import check_partition
    >>> check_partition(system)                       # returns nothing: the guards are a partition

    Guards that leave a gap are refused with the region that is not covered:

    >>> gap = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...               guard=Polytope(np.array([[-1.0, 0.0]]), np.array([-1.0])), name="right")   # x >= 1
    >>> check_partition(PWASystem((left, gap), system.state_bounds, system.input_bounds))
    Traceback (most recent call last):
    ...
    hybobs_opt.errors.ModelError: modes[*].guard: expected guards whose union covers X x U ...
    """
    key = _partition_key(system, overlaps)
    if key in _PARTITION_OUTCOMES:
        _PARTITION_OUTCOMES.move_to_end(key)
        failure = _PARTITION_OUTCOMES[key]
        if failure is not None:
            raise ModelError(*failure)
        return
    try:
        _check_partition(system, overlaps)
    except ModelError as exc:
        _remember_partition(key, (exc.field, exc.expected, exc.got))
        raise
    _remember_partition(key, None)


def _remember_partition(key: bytes, outcome: tuple | None) -> None:
    _PARTITION_OUTCOMES[key] = outcome
    while len(_PARTITION_OUTCOMES) > _PARTITION_OUTCOMES_MAX:
        _PARTITION_OUTCOMES.popitem(last=False)


def _interior_by_slack_lp(P: Polytope, scale: np.ndarray, radius_bound: float) -> bool | None:
    """Whether ``P`` (a subset of ``X x U``) holds a ball of radius above ``FULL_DIMENSION_RTOL`` in
    ``z / scale``, decided by the certified max-slack LP, or ``None``.

    :func:`~hybobs_opt.geometry.lp.max_slack` (DAQP, both bounds proven in numpy, HiGHS behind it)
    solves the Chebyshev-ball LP; every point of ``X x U`` has ``||z / scale|| <= radius_bound``,
    which bounds its dual certificate.  It decides only when a certified bound clears the threshold
    by :data:`~hybobs_opt.tolerances.PARTITION_INTERIOR_MARGIN` of it (a ball that much larger fits
    around its point, or the dual bound is that much below); otherwise ``None`` sends the caller to
    :meth:`~hybobs_opt.geometry.Polytope.chebyshev_ball`, so near the threshold the decision is the
    one that path always took.  The proof's sets are mostly flat or empty, where the Chebyshev
    LP's vertex certificate fails on the degenerate optimum and HiGHS used to be called for each.
    """
    from ..geometry.lp import max_slack

    res = max_slack(P.A * scale[None, :], P.b, radius_bound=radius_bound, threshold=FULL_DIMENSION_RTOL,
                    problem="partition proof (interior of a piece)")
    if res.lower > (1.0 + PARTITION_INTERIOR_MARGIN) * FULL_DIMENSION_RTOL:
        return True
    if res.upper < (1.0 - PARTITION_INTERIOR_MARGIN) * FULL_DIMENSION_RTOL:
        return False
    return None


def _check_partition(system: PWASystem, overlaps: bool) -> None:
    from ..geometry.difference import polytope_difference

    domain = system.domain
    lo, hi = domain.bounding_box()
    scale = np.where(hi - lo > 0, hi - lo, 1.0)
    # every point of X x U in z / scale lies in this ball; the factor covers the rounding of the
    # norm's d squares, sum and square root (at most (d + 2) units in the last place, relative)
    corner = np.maximum(np.abs(lo), np.abs(hi)) / scale
    radius_bound = float(np.linalg.norm(corner)) * (1.0 + (corner.size + 2) * np.finfo(float).eps)

    def has_interior(P: Polytope) -> bool:
        decided = _interior_by_slack_lp(P, scale, radius_bound)
        return P.is_full_dimensional(scale) if decided is None else decided

    guards = [mode.guard.intersect(domain) for mode in system.modes]
    if overlaps:
        for i in range(len(guards)):
            for j in range(i + 1, len(guards)):
                common = guards[i].intersect(guards[j])
                if _interior_by_slack_lp(common, scale, radius_bound) is False:
                    continue
                centre, radius = common.chebyshev_ball(scale)
                if centre is not None and radius > FULL_DIMENSION_RTOL:
                    raise ModelError(
                        f"modes[{i}].guard and modes[{j}].guard ({system.modes[i].name}, {system.modes[j].name})",
                        "guards that do not overlap (or partition='ordered' to resolve overlaps by mode order)",
                        f"a common interior around {_point_text(system, centre)}")
    pieces = [domain]
    for guard in guards:
        # only tested for an interior: kept with their redundant rows (no vertex enumeration per piece)
        pieces = [piece for region in pieces
                  for piece in polytope_difference(region, guard, scale, irredundant=False, interior_test=has_interior)]
        if not pieces:
            return
    centre, _ = pieces[0].chebyshev_ball(scale)
    raise ModelError("modes[*].guard", "guards whose union covers X x U (or partition='none')",
                     f"a gap around {_point_text(system, centre)} that no guard contains")


def _point_text(system: PWASystem, z: np.ndarray) -> str:
    names = system.state_names + system.input_names
    return "(" + ", ".join(f"{nm}={v:.6g}" for nm, v in zip(names, z)) + ")"
