"""The event-sampled model of a constant-drift hybrid system, Section 3 of paper 003.

Paper 003 ("Observer design for piecewise affine hybrid systems with constant drift") samples
system (3) in three steps, all computed here from the data ``f_q, k_q, alpha_q`` of a
:class:`~hybobs_opt.systems.constant_drift.ConstantDriftSystem`:

1. at every event ``t_k`` (eqs. 11-12): ``x(t_{k+1}^-) = A~_q x(t_k^-) + a~_q`` and
   ``t_{k+1} = t_k + C~_q x(t_k^-) + c~_q`` with ``q = q(t_k^-)`` the mode *left* at ``t_k``;
2. without the timer ``x0``, which is 0 just before every event (Lemma 2.7; eq. 13):
   ``A-bar_q, a-bar_q, C-bar_q, c-bar_q``;
3. at the visible events only (eqs. 14-15): a ``V``-periodic affine system
   ``x-bar(t^v_{j+1}) = A_j x-bar(t^v_j) + a_j``, ``t^v_{j+1} = t^v_j + C_j x-bar(t^v_j) + c_j``.

Indexing.  Modes are numbered ``1 ... Q`` as in the paper; the per-mode arrays below are
indexed by ``q - 1``.  The visible events leave the modes ``v_1 < ... < v_V`` of ``V``
(Section 2.4); *phase* ``j`` (``1 ... V``, array index ``j - 1``) is the step from the visible
event that leaves ``v_j`` to the next one, which leaves ``sigma_v(v_j)`` (eq. 10).  This is the
paper's ``A_j`` of Section 5: for the T-junction ``A_1`` maps "enter serve flow 1" to "leave
serve flow 1" and ``A_2`` maps "leave serve flow 1" to the next "enter serve flow 1".

Eq. (15) is evaluated as the composition of the maps (13) of the modes traversed between two
visible events (the products and sums of (15a-h) are exactly that composition, with the
wrap-around of (15e-h) handled by walking the cycle).

Note on eq. (12a-b): the extracted text reads ``a~_q = alpha_q A_q e_1`` and
``c~_q = alpha_q C_q e_1``; with the reset ``x+ = x + alpha_q e_1`` (eq. 2) followed by the flow
in ``sigma(q)`` the only consistent reading (and the one that reproduces the printed matrices of
Section 3.1) is ``a~_q = alpha_q A~_q e_1`` and ``c~_q = alpha_q C~_q e_1``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError
from .._validate import as_int, as_items, as_vector, names_or_default, real_array
from .constant_drift import ConstantDriftSystem


def _ro(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class EventMaps:
    """The system sampled at all events, eqs. (11)-(13) of paper 003.

    Parameters
    ----------
    system : ConstantDriftSystem
        The system the maps were computed from.
    A_tilde : (Q, N+1, N+1) array
        ``A~_q`` of eq. (12a), ``q = 1 ... Q`` at index ``q - 1``.
    a_tilde : (Q, N+1) array
        ``a~_q = alpha_q A~_q e_1`` (eq. 12a).
    C_tilde : (Q, N+1) array
        ``C~_q`` of eq. (12b) (rows).
    c_tilde : (Q,) array
        ``c~_q = alpha_q C~_q e_1`` (eq. 12b).
    A_bar, a_bar, C_bar, c_bar : arrays of shapes (Q, N, N), (Q, N), (Q, N), (Q,)
        The reduced maps of eq. (13), without the timer ``x0``.

    See Also
    --------
    event_maps : computes them.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import event_maps
    >>> maps = event_maps(server)
    >>> maps.A_bar[0].round(3), maps.C_bar[0].round(3)    # mode 1: queue state and time to its event
    (array([[0. , 0. ],
           [1.5, 1. ]]), array([0.5, 0. ]))
    """

    system: ConstantDriftSystem
    A_tilde: np.ndarray
    a_tilde: np.ndarray
    C_tilde: np.ndarray
    c_tilde: np.ndarray
    A_bar: np.ndarray
    a_bar: np.ndarray
    C_bar: np.ndarray
    c_bar: np.ndarray

    def step_all(self, x_minus: ArrayLike, q: int) -> tuple[np.ndarray, float]:
        """``(x(t_{k+1}^-), t_{k+1} - t_k)`` from ``x(t_k^-)`` when mode ``q`` is left at ``t_k`` (eq. 11).

        Parameters
        ----------
        x_minus : (N+1,) array_like
            State ``x(t_k^-)`` just before the event (timer included).
        q : int
            Mode left at ``t_k``, in ``1..Q``.

        Returns
        -------
        x_next : (N+1,) ndarray
            ``A~_q x + a~_q``, the state just before the next event.
        dt : float
            ``C~_q x + c~_q``, the time to the next event.
        """
        self.system._check_mode(q, "q")
        x = as_vector(x_minus, "x_minus", self.system.n_states)
        i = q - 1
        return self.A_tilde[i] @ x + self.a_tilde[i], float(self.C_tilde[i] @ x + self.c_tilde[i])

    def step_reduced(self, x_bar: ArrayLike, q: int) -> tuple[np.ndarray, float]:
        """``(x-bar(t_{k+1}), t_{k+1} - t_k)`` from ``x-bar(t_k)`` when mode ``q`` is left at ``t_k`` (eq. 13).

        Parameters
        ----------
        x_bar : (N,) array_like
            Reduced state ``x-bar(t_k)`` (buffers only, no timer).
        q : int
            Mode left at ``t_k``, in ``1..Q``.

        Returns
        -------
        x_next : (N,) ndarray
            ``A-bar_q x + a-bar_q``.
        dt : float
            ``C-bar_q x + c-bar_q``, the time to the next event.
        """
        self.system._check_mode(q, "q")
        x = as_vector(x_bar, "x_bar", self.system.n_buffers)
        i = q - 1
        return self.A_bar[i] @ x + self.a_bar[i], float(self.C_bar[i] @ x + self.c_bar[i])


def event_maps(system: ConstantDriftSystem) -> EventMaps:
    """Sample ``system`` at all events and remove the timer: eqs. (11), (12a-b) and (13) of paper 003.

    Implements ``A~_q = I + f_s e_{k_s}^T / (-e_{k_s}^T f_s)``, ``C~_q = e_{k_s}^T / (-e_{k_s}^T f_s)``
    with ``s = sigma(q)`` (eq. 12), ``a~_q = alpha_q A~_q e_1``, ``c~_q = alpha_q C~_q e_1``, and the
    reduction ``A-bar_q = [0 I] A~_q [0 I]^T``, ``a-bar_q = [0 I] a~_q``, ``C-bar_q = C~_q [0 I]^T``,
    ``c-bar_q = c~_q`` (eq. 13).

    Parameters
    ----------
    system : ConstantDriftSystem
        A system satisfying Assumptions 2.1-2.6 (checked when it was built).

    Returns
    -------
    EventMaps

    Raises
    ------
    ModelError
        If ``system`` is not a ``ConstantDriftSystem``.

    See Also
    --------
    EventMaps : what it returns.
    periodic_system : the maps composed between visible events.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import event_maps
    >>> maps = event_maps(server)
    >>> maps.A_tilde.shape, maps.A_bar.shape      # per mode: with the timer (11), without it (13)
    ((4, 3, 3), (4, 2, 2))
    """
    if not isinstance(system, ConstantDriftSystem):
        raise ModelError("system", "a ConstantDriftSystem (paper 003, eq. 3)", type(system).__name__)
    Q, n = system.n_modes, system.n_states
    At = np.zeros((Q, n, n))
    at = np.zeros((Q, n))
    Ct = np.zeros((Q, n))
    ct = np.zeros(Q)
    e1 = np.zeros(n)
    e1[0] = 1.0
    for q in range(1, Q + 1):
        s = system.successor(q)
        f = system.f[s - 1]
        k = int(system.trigger[s - 1])
        rate = -f[k]  # > 0 by Assumption 2.1
        ek = np.zeros(n)
        ek[k] = 1.0
        At[q - 1] = np.eye(n) + np.outer(f, ek) / rate
        Ct[q - 1] = ek / rate
        alpha = system.alpha[q - 1]
        at[q - 1] = alpha * At[q - 1] @ e1
        ct[q - 1] = alpha * Ct[q - 1] @ e1
    return EventMaps(
        system=system,
        A_tilde=_ro(At),
        a_tilde=_ro(at),
        C_tilde=_ro(Ct),
        c_tilde=_ro(ct),
        A_bar=_ro(At[:, 1:, 1:]),
        a_bar=_ro(at[:, 1:]),
        C_bar=_ro(Ct[:, 1:]),
        c_bar=_ro(ct),
    )


@dataclass(frozen=True, eq=False)
class PeriodicSystem:
    """The ``V``-periodic affine system (14) sampled at the visible events, paper 003.

    ``x-bar(t^v_{j+1}) = A_j x-bar(t^v_j) + a_j`` and ``t^v_{j+1} = t^v_j + C_j x-bar(t^v_j) + c_j``
    where phase ``j`` is the step that starts at the visible event leaving mode ``v_j``.

    Parameters
    ----------
    A : (V, N, N) array
    a : (V, N) array
    C : (V, N) array
        ``C_j`` as rows.
    c : (V,) array
    event_modes : tuple of int
        ``(v_1, ..., v_V)``: the mode left at the visible event that starts each phase.
    segments : tuple of tuple of int
        The modes whose maps (13) are composed in each phase: ``v_j, sigma(v_j), ...`` up to (not
        including) ``sigma_v(v_j)``.
    visible_modes : tuple of int
        ``Q_v`` used to build it (eq. 8).
    system : ConstantDriftSystem or None
        The source system (``None`` for a periodic system given by its matrices).
    state_names : tuple of str
        Names of ``x1 ... xN``.

    See Also
    --------
    periodic_system : computes it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import periodic_system
    >>> periodic = periodic_system(server)
    >>> len(periodic.segments), periodic.segments      # the modes each phase passes through
    (2, ((3,), (4, 1, 2)))
    """

    A: np.ndarray
    a: np.ndarray
    C: np.ndarray
    c: np.ndarray
    event_modes: tuple[int, ...]
    segments: tuple[tuple[int, ...], ...]
    visible_modes: tuple[int, ...]
    system: ConstantDriftSystem | None = None
    state_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        A = real_array(self.A, "A", "an array of V square matrices, shape (V, N, N)")
        if A.ndim != 3 or A.shape[1] != A.shape[2] or A.shape[0] < 1 or A.shape[1] < 1:
            raise ModelError("A", "an array of V square matrices, shape (V, N, N)", f"shape {A.shape}")
        V, N, _ = A.shape
        a = real_array(self.a, "a", f"an array of shape ({V}, {N})")
        C = real_array(self.C, "C", f"an array of shape ({V}, {N})")
        c = real_array(self.c, "c", f"a vector of length {V}").reshape(-1)
        for name, arr, shape in (("a", a, (V, N)), ("C", C, (V, N)), ("c", c, (V,))):
            if arr.shape != shape:
                raise ModelError(name, f"shape {shape}", f"shape {arr.shape}")
        for name, arr in (("A", A), ("a", a), ("C", C), ("c", c)):
            if not np.all(np.isfinite(arr)):
                raise ModelError(name, "finite entries", "NaN or Inf")
        event_modes = tuple(as_int(v, f"event_modes[{i}]", 1, "a mode number (an integer >= 1)")
                            for i, v in enumerate(as_items(self.event_modes, "event_modes", (int, np.integer), "mode numbers")))
        if len(event_modes) != V:
            raise ModelError("event_modes", f"{V} modes (one per phase)", f"{len(event_modes)}")
        segments = []
        for k, seg in enumerate(as_items(self.segments, "segments", (tuple, list), "sequences of mode numbers")):
            segments.append(tuple(as_int(q, f"segments[{k}][{i}]", 1, "a mode number (an integer >= 1)")
                                  for i, q in enumerate(as_items(seg, f"segments[{k}]", (int, np.integer), "mode numbers"))))
        visible = tuple(as_int(q, f"visible_modes[{i}]", 1, "a mode number (an integer >= 1)")
                        for i, q in enumerate(as_items(self.visible_modes, "visible_modes", (int, np.integer), "mode numbers")))
        if self.system is not None and not isinstance(self.system, ConstantDriftSystem):
            raise ModelError("system", "the ConstantDriftSystem it was sampled from, or None", type(self.system).__name__)
        names = names_or_default(self.state_names, "state_names", tuple(f"x{i}" for i in range(1, N + 1)))
        for name, arr in (("A", A), ("a", a), ("C", C), ("c", c)):
            object.__setattr__(self, name, _ro(arr))
        object.__setattr__(self, "event_modes", event_modes)
        object.__setattr__(self, "segments", tuple(segments))
        object.__setattr__(self, "visible_modes", visible)
        object.__setattr__(self, "state_names", names)

    # ------------------------------------------------------------------ sizes
    @property
    def period(self) -> int:
        """``V``, the number of visible events per cycle (the period of eq. 14)."""
        return self.A.shape[0]

    @property
    def n(self) -> int:
        """``N``, the dimension of the reduced state ``x-bar``."""
        return self.A.shape[1]

    def phase_of(self, v: int) -> int:
        """Phase ``j`` (1-based) of the visible event that leaves mode ``v``.

        Parameters
        ----------
        v : int
            Mode number, one of :attr:`event_modes`.

        Returns
        -------
        int
            The phase, ``1 ... V``.

        Raises
        ------
        ModelError
            If ``v`` is not in ``V``.
        """
        try:
            return self.event_modes.index(int(v)) + 1
        except ValueError:
            raise ModelError("v", f"a mode whose leaving event is visible, one of {self.event_modes}", repr(v)) from None

    def next_phase(self, j: int) -> int:
        """``j + 1`` cyclically (``sigma_v`` of eq. 10 on phases).

        Parameters
        ----------
        j : int
            Phase in ``1..V``.

        Returns
        -------
        int
            The next phase, ``1 ... V``.
        """
        return 1 + (j % self.period)

    # ------------------------------------------------------------------ maps
    def step(self, j: int, x_bar: ArrayLike) -> tuple[np.ndarray, float]:
        """One step of (14) in phase ``j``: ``(A_j x + a_j, C_j x + c_j)`` (state, time to next visible event).

        Parameters
        ----------
        j : int
            Phase in ``1..V``.
        x_bar : (N,) array_like
            Reduced state at the visible event that starts phase ``j``.

        Returns
        -------
        x_next : (N,) ndarray
            The state at the next visible event.
        dt : float
            The time until it.

        Raises
        ------
        ModelError
            If ``j`` is not a phase in ``1..V`` or ``x_bar`` has the wrong length.
        """
        x = as_vector(x_bar, "x_bar", self.n)
        i = self._index(j)
        return self.A[i] @ x + self.a[i], float(self.C[i] @ x + self.c[i])

    def closed_loop(self, L: ArrayLike) -> np.ndarray:
        """``A_j - L_j C_j`` for every phase (the error dynamics of observer (16)); ``L`` has shape (V, N).

        Parameters
        ----------
        L : (V, N) array_like
            Observer gains, ``L_j`` as row ``j - 1`` (checked by :meth:`check_gains`).

        Returns
        -------
        (V, N, N) ndarray
            ``A_j - L_j C_j`` stacked by phase.
        """
        L = self.check_gains(L)
        return self.A - L[:, :, None] * self.C[:, None, :]

    def monodromy(self, L: ArrayLike | None = None, start: int = 1) -> np.ndarray:
        """Product of the (closed-loop) matrices over one period starting at phase ``start``.

        ``Phi = M_{start-1} ... M_{start+1} M_start`` (left multiplication, the paper's product
        convention) with ``M_j = A_j - L_j C_j``, or ``M_j = A_j`` when ``L`` is ``None``.

        Parameters
        ----------
        L : (V, N) array_like, optional
            Observer gains (one row per phase); ``None`` gives the open-loop product of the ``A_j``.
        start : int, default 1
            Phase (``1..V``) whose matrix is applied first.

        Returns
        -------
        (N, N) ndarray
            The product over one period.
        """
        M = self.A if L is None else self.closed_loop(L)
        i0 = self._index(start)
        out = np.eye(self.n)
        for s in range(self.period):
            out = M[(i0 + s) % self.period] @ out
        return out

    def transition(self, M: np.ndarray, start: int, steps: int) -> np.ndarray:
        """``M_{start+steps-1} ... M_start`` for per-phase matrices ``M`` (shape (V, N, N)).

        Parameters
        ----------
        M : (V, N, N) ndarray
            One matrix per phase, e.g. ``A`` or :meth:`closed_loop`.
        start : int
            Phase (``1..V``) whose matrix is applied first.
        steps : int
            Number of factors; phases wrap around cyclically (``steps = 0`` gives the identity).

        Returns
        -------
        (N, N) ndarray
            The product over ``steps`` phases.
        """
        i0 = self._index(start)
        out = np.eye(self.n)
        for s in range(steps):
            out = M[(i0 + s) % self.period] @ out
        return out

    def observability_matrix(self, start: int, T: int) -> np.ndarray:
        """Rows ``C_j, C_{j+1} A_j, ...`` of ``T`` consecutive event-time increments from phase ``start``.

        The window-start state is determined by ``T`` visible-event times iff this has rank ``N``.

        Parameters
        ----------
        start : int
            Phase (``1..V``) of the window's first visible event.
        T : int
            Number of consecutive event-time increments (rows).

        Returns
        -------
        (T, N) ndarray
            Row ``s`` is ``C_{j+s} A_{j+s-1} ... A_j`` with phases taken cyclically.
        """
        i0 = self._index(start)
        rows, P = [], np.eye(self.n)
        for s in range(T):
            i = (i0 + s) % self.period
            rows.append(self.C[i] @ P)
            P = self.A[i] @ P
        return np.array(rows)

    def check_gains(self, L: ArrayLike, field: str = "L") -> np.ndarray:
        """Return observer gains ``L`` as a (V, N) float array; one column ``L_j`` per phase as a row.

        Parameters
        ----------
        L : (V, N) array_like
            Gains to check: real, finite, one row per phase.
        field : str, default "L"
            Name of ``L`` in the :class:`ModelError` raised on bad gains.

        Returns
        -------
        (V, N) ndarray
            The gains, one row per phase.

        Raises
        ------
        ModelError
            If ``L`` is complex, non-finite or not of shape ``(V, N)``.
        """
        arr = real_array(L, field, f"gains of shape ({self.period}, {self.n})")  # complex gains refused, not cast
        if arr.shape != (self.period, self.n):
            raise ModelError(field, f"gains of shape ({self.period}, {self.n}) (one L_j per phase)", f"shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ModelError(field, "finite gains", f"{arr.tolist()}")
        return arr

    def _index(self, j: int) -> int:
        if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or not 1 <= int(j) <= self.period:
            raise ModelError("j", f"a phase in 1..{self.period}", repr(j))
        return int(j) - 1


def visible_event_set(system: ConstantDriftSystem, visible_modes: Sequence[int] | None = None) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """``(Q_v, V)`` of Section 2.4 for the system's outputs or for a chosen set of visible modes.

    Parameters
    ----------
    system : ConstantDriftSystem
        The system of eq. (3) of paper 003.
    visible_modes : sequence of int, optional
        Modes taken as visible (``Q_v``); ``None`` uses the system's outputs ``h_q``.

    Returns
    -------
    Q_v : tuple of int
        The visible modes, sorted.
    V : tuple of int
        The modes whose leaving event is visible, sorted: ``Q_v`` and the modes ``q`` with
        ``sigma(q)`` in ``Q_v``.

    Raises
    ------
    ModelError
        If ``visible_modes`` is empty (Assumption 2.6) or names a mode outside ``1 ... Q``.

    See Also
    --------
    periodic_system : the system sampled at the visible events.

    Examples
    --------
    Only "serve type 2" has an output, so only the events leaving it are visible:

    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import visible_event_set
    >>> visible_event_set(server)
    ((4,), (3, 4))
    """
    if not isinstance(system, ConstantDriftSystem):
        raise ModelError("system", "a ConstantDriftSystem (paper 003, eq. 3)", type(system).__name__)
    if visible_modes is None:
        return system.visible_modes, system.visible_event_modes
    if isinstance(visible_modes, (set, frozenset)):
        visible_modes = sorted(visible_modes, key=lambda q: (not isinstance(q, (int, np.integer)), str(q)))
    items = as_items(visible_modes, "visible_modes", (int, np.integer), "mode numbers")
    qv = sorted({as_int(q, f"visible_modes[{i}]", None, "a mode number (an integer)") for i, q in enumerate(items)})
    if not qv:
        raise ModelError("Assumption 2.6", "at least one visible mode (h_q = q)", "an empty set of visible modes")
    for q in qv:
        if not 1 <= q <= system.n_modes:
            raise ModelError("visible_modes", f"mode numbers in 1..{system.n_modes}", f"{q}")
    v = sorted({q for q in range(1, system.n_modes + 1) if q in qv or system.successor(q) in qv})
    return tuple(qv), tuple(v)


def periodic_system(system: ConstantDriftSystem, visible_modes: Sequence[int] | None = None) -> PeriodicSystem:
    """Sample ``system`` at its visible events: the periodic system (14)-(15) of paper 003.

    Implements eqs. (15a-h): for phase ``j`` the maps (13) of the modes ``v_j, sigma(v_j), ...,
    sigma_v(v_j) - 1`` are composed, ``(A, a, C, c) <- (A-bar_q A, A-bar_q a + a-bar_q,
    C + C-bar_q A, c + C-bar_q a + c-bar_q)``, which is (15a-d) and, across the end of the
    cycle, (15e-h).

    Parameters
    ----------
    system : ConstantDriftSystem
    visible_modes : sequence of int, optional
        The set ``Q_v`` of visible modes; by default the system's own (``h_q = q``).  Giving it
        here evaluates other sensor placements without rebuilding the system.

    Returns
    -------
    PeriodicSystem

    Raises
    ------
    ModelError
        If ``system`` is not a ``ConstantDriftSystem`` or ``visible_modes`` is empty
        ("Assumption 2.6") or out of range.

    See Also
    --------
    PeriodicSystem : what it returns.
    phase_augmented_pwa : the same as a time-invariant PWA system.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import periodic_system
    >>> periodic = periodic_system(server)
    >>> periodic.visible_modes, periodic.event_modes, periodic.A.shape
    ((4,), (3, 4), (2, 2, 2))
    >>> periodic.A[0].round(3)
    array([[1.  , 0.25],
           [0.  , 0.  ]])
    """
    maps = event_maps(system)
    qv, V = visible_event_set(system, visible_modes)
    Nb = system.n_buffers
    As, as_, Cs, cs, segs = [], [], [], [], []
    for l, v in enumerate(V):
        v_next = V[(l + 1) % len(V)]
        A, a, C, c = np.eye(Nb), np.zeros(Nb), np.zeros(Nb), 0.0
        seg = []
        q = v
        while True:
            i = q - 1
            c = c + float(maps.C_bar[i] @ a) + float(maps.c_bar[i])
            C = C + maps.C_bar[i] @ A
            a = maps.A_bar[i] @ a + maps.a_bar[i]
            A = maps.A_bar[i] @ A
            seg.append(q)
            q = system.successor(q)
            if q == v_next:
                break
        As.append(A)
        as_.append(a)
        Cs.append(C)
        cs.append(c)
        segs.append(tuple(seg))
    return PeriodicSystem(
        A=np.array(As),
        a=np.array(as_),
        C=np.array(Cs),
        c=np.array(cs),
        event_modes=V,
        segments=tuple(segs),
        visible_modes=qv,
        system=system,
        state_names=system.state_names[1:],
    )


def phase_augmented_pwa(ps: PeriodicSystem, upper: ArrayLike, lower: ArrayLike | None = None):
    """The periodic system (14) as a time-invariant PWA system (paper 002, eq. 1) with a phase state.

    The state is ``[x-bar; phi]`` with ``phi = j - 1`` the phase; region ``j`` is
    ``|phi - (j - 1)| <= 1/2`` (full-dimensional, as paper 002 requires) with dynamics
    ``x-bar+ = A_j x-bar + a_j``, ``phi+ = phi + 1`` (``phi - (V - 1)`` in the last phase) and
    output ``[C_j x-bar + c_j; phi]``: the time to the next visible event and the phase, which is
    known from ``y`` (the mode left at each visible event).  This is how the lookup-table observer
    of paper 002 can read the event-sampled data.

    Parameters
    ----------
    ps : PeriodicSystem
    upper : (N,) array_like
        Upper bounds of the queues in the state box ``X``.
    lower : (N,) array_like, optional
        Lower bounds (default ``-0.05 upper``): queues are 0 right after they are emptied, and
        the lookup observer needs candidates strictly inside ``X``, so the box reaches a little
        below 0.

    Returns
    -------
    PWASystem

    See Also
    --------
    periodic_system : the periodic system it encodes.
    hybobs_opt.regions.analyse_observability : Algorithm 3.1 applies to the result.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> from hybobs_opt.systems import periodic_system, phase_augmented_pwa
    >>> pwa = phase_augmented_pwa(periodic_system(server), [10.0, 10.0])   # queues bounded by 10
    >>> pwa
    PWASystem(name='event-sampled (14) with phase', n=3, m=0, p=2, modes=2)
    >>> pwa.state_names
    ('x1', 'x2', 'phase')
    """
    from ..geometry.polytope import Polytope
    from .pwa import PWAMode, PWASystem

    if not isinstance(ps, PeriodicSystem):
        raise ModelError("ps", "a PeriodicSystem (periodic_system(...), eq. 14 of paper 003)", type(ps).__name__)
    V, N = ps.period, ps.n
    hi = as_vector(upper, "upper", N)
    lo = -0.05 * hi if lower is None else as_vector(lower, "lower", N)
    if np.any(hi <= lo):
        raise ModelError("upper", "bounds above the lower bounds", f"{hi.tolist()} vs {lo.tolist()}")
    modes = []
    for j in range(V):
        A = np.zeros((N + 1, N + 1))
        A[:N, :N] = ps.A[j]
        A[N, N] = 1.0
        a = np.append(ps.a[j], 1.0 if j < V - 1 else -(V - 1.0))
        C = np.zeros((2, N + 1))
        C[0, :N] = ps.C[j]
        C[1, N] = 1.0
        guard = Polytope.from_box(np.append(lo, j - 0.5), np.append(hi, j + 0.5))
        modes.append(PWAMode(A=A, B=np.zeros((N + 1, 0)), a=a, C=C, c=np.array([ps.c[j], 0.0]), guard=guard,
                             name=f"phase {j + 1}"))
    box = Polytope.from_box(np.append(lo, -0.5), np.append(hi, V - 0.5))
    return PWASystem(modes=tuple(modes), state_bounds=box, state_names=ps.state_names + ("phase",),
                     output_names=("dt", "phase"), name="event-sampled (14) with phase")


__all__ = ["EventMaps", "PeriodicSystem", "event_maps", "periodic_system", "phase_augmented_pwa", "visible_event_set"]
