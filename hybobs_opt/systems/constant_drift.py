"""Piecewise affine hybrid systems with constant drift and a fixed cyclic mode order.

Implements the system class (3) of paper 003 ("Observer design for piecewise affine hybrid
systems with constant drift"), Section 2.2, with Assumptions 2.1-2.6 checked on construction.

Conventions (the paper's text extraction garbled some formulas; what is assumed here is
rederived from the surrounding text and the server/traffic physics of Sections 2.1 and 5):

* The continuous state is ``x = [x0, x1, ..., xN]`` in ``R_+^{N+1}``; ``x0`` is the remaining
  setup (clearing) time, ``x1 ... xN`` are buffer contents / queue lengths.  Python index ``i``
  of ``x`` is the paper's subscript of ``x_i``.
* Modes are numbered ``1 ... Q`` as in the paper, because the output of a visible mode *is* its
  number (``y = h_q = q``) and ``y = 0`` means "no information"; a 0-based mode index would
  collide with that.
* ``trigger[q-1]`` is the 0-based index into ``x`` of the component whose reaching zero ends
  mode ``q``; the paper's 1-based ``k_q`` (``e_{k_q}`` with ``e_1`` selecting ``x0``) equals
  ``trigger + 1`` and is available as :attr:`ConstantDriftSystem.k`.
* Flow set of (3a): ``e_{k_q}^T x >= 0``; jump set of (3b): ``e_{k_q}^T x = 0``.  The reset (2),
  (3b) adds ``alpha_q`` to ``x0`` where ``q`` is the mode being *left*, and the next mode is
  ``sigma(q) = 1 + (q mod Q)`` (eq. 1).
* Assumption 2.3 is read as ``alpha_q > 0  <=>  k_{sigma(q)} = 1`` and Assumption 2.5 as
  ``k_q = 1  =>  k_{sigma(q)} != 1`` (the ``<=>`` and ``!=`` signs were lost in extraction; the
  sentences after each assumption fix their meaning).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError
from ._model_io import ModelDictMixin
from .._validate import as_matrix, as_vector, names_or_default


class NextEvent(NamedTuple):
    """The next event of a constant-drift system from a given state (see ``next_event``).

    Attributes
    ----------
    dwell : float
        Time until the event, ``x[k_q] / (-f_q[k_q])``.
    x_minus : ndarray
        State just before the jump, ``x(t_k^-)``; its triggering component is exactly 0.
    x_plus : ndarray
        State just after the jump, ``x(t_k^+) = x(t_k^-) + alpha_q e_1`` (eq. 2).
    from_mode, to_mode : int
        ``q`` and ``sigma(q)``.
    visible : bool
        Whether the event is visible (``q`` in the set ``V`` of Section 2.4).
    """

    dwell: float
    x_minus: np.ndarray
    x_plus: np.ndarray
    from_mode: int
    to_mode: int
    visible: bool


def _as_int_vector(value, field_name: str, size: int) -> np.ndarray:
    """Return ``value`` as a read-only 1-D int array of length ``size``; floats and bools are refused."""
    if value is None or isinstance(value, (str, bytes)):
        raise ModelError(field_name, f"a vector of {size} integers", repr(value))
    try:
        arr = np.array(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise ModelError(field_name, f"a vector of {size} integers", f"{type(value).__name__} ({exc})") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ModelError(field_name, f"a vector of {size} integers", f"shape {arr.shape}")
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        # 1.0 is refused on purpose: a float index is most likely a modelling slip.
        raise ModelError(field_name, f"a vector of {size} integers", f"dtype {arr.dtype}: {arr.tolist()}")
    if arr.shape[0] != size:
        raise ModelError(field_name, f"a vector of {size} integers", f"length {arr.shape[0]}")
    arr = arr.astype(np.int64)
    arr.setflags(write=False)
    return arr


def _names(value: Sequence[str] | None, field_name: str, defaults: tuple[str, ...]) -> tuple[str, ...]:
    return names_or_default(value, field_name, defaults)


@dataclass(frozen=True, eq=False)
class ConstantDriftSystem(ModelDictMixin):
    """Piecewise affine hybrid system with constant drift, eq. (3) of paper 003.

    In mode ``q`` the state flows as ``dx/dt = f_q`` while ``x[trigger_q] >= 0`` (eq. 3a).  When
    ``x[trigger_q]`` reaches 0 the system jumps (eq. 3b): ``x0 += alpha_q`` and
    ``q -> sigma(q) = 1 + (q mod Q)`` (eq. 1).  The output in mode ``q`` is ``y = h_q`` with
    ``h_q in {0, q}``: mode ``q`` is visible when ``h_q = q`` (eq. 8).

    Parameters
    ----------
    f : (Q, N+1) array
        Drift vectors ``f_q`` as rows; column 0 is the timer ``x0``.
    trigger : (Q,) int array
        0-based index into ``x`` of the component whose reaching zero ends each mode (the paper's
        ``k_q - 1``).
    alpha : (Q,) array
        Reset amounts ``alpha_q >= 0`` added to ``x0`` when mode ``q`` is left (eq. 2).
    h : (Q,) int array
        Outputs ``h_q``, each 0 (invisible) or ``q`` (visible).
    state_names : sequence of str, optional
        Names of ``x0 ... xN`` (default ``("x0", ..., "xN")``, the paper's names).
    mode_names : sequence of str, optional
        Names of modes ``1 ... Q`` (default ``("mode 1", ...)``).

    Raises
    ------
    ModelError
        On wrong shapes, non-finite entries, non-integer ``trigger``/``h``, ``h_q`` not in
        ``{0, q}``, or a violated Assumption 2.1-2.6; the error's ``field`` names the assumption
        and the mode, e.g. ``"Assumption 2.3 (mode 2)"``.

    See Also
    --------
    hybobs_opt.sim.simulate_constant_drift : its exact simulation.
    event_maps, periodic_system : the system sampled at its events.

    Notes
    -----
    The data are kept exactly as the paper states them so that the event-sampled model of
    Section 3 (eqs. 11-15: ``A~_q = I + f_{sigma(q)} e_{k_sigma(q)}^T / (-e_{k_sigma(q)}^T f_{sigma(q)})``
    and so on) can be computed from ``f``, ``trigger``, ``alpha``, :meth:`successor` and
    :attr:`visible_event_modes` alone.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> server = get_example("switching_server").build()           # Section 2.1 of paper 003
    >>> server.mode_names
    ('setup type 1', 'serve type 1', 'setup type 2', 'serve type 2')
    >>> server.f.shape, server.trigger, server.alpha, server.h    # drifts, triggers, resets, outputs
    ((4, 3), array([0, 1, 0, 2]), array([0., 1., 0., 2.]), array([0, 0, 0, 4]))
    """

    f: np.ndarray
    trigger: np.ndarray
    alpha: np.ndarray
    h: np.ndarray
    state_names: tuple[str, ...] = field(default=())
    mode_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        f = as_matrix(self.f, "f", (None, None))
        Q, n = f.shape
        if Q < 1:
            raise ModelError("f", "at least one mode (one row)", f"shape {f.shape}")
        if n < 2:
            raise ModelError("f", "at least 2 columns: the timer x0 and one buffer (N >= 1)", f"shape {f.shape}")
        trigger = _as_int_vector(self.trigger, "trigger", Q)
        bad = np.nonzero((trigger < 0) | (trigger >= n))[0]
        if bad.size:
            q = int(bad[0]) + 1
            raise ModelError(f"trigger (mode {q})", f"a state index in 0..{n - 1}", f"{int(trigger[q - 1])}")
        alpha = as_vector(self.alpha, "alpha", Q)
        bad = np.nonzero(alpha < 0)[0]
        if bad.size:
            q = int(bad[0]) + 1
            raise ModelError(f"alpha (mode {q})", "alpha_q >= 0 (a setup time, R_+ in eq. 2)", f"{alpha[q - 1]}")
        h = _as_int_vector(self.h, "h", Q)
        for q in range(1, Q + 1):
            if int(h[q - 1]) not in (0, q):
                raise ModelError(f"h (mode {q})", f"h_q in {{0, {q}}} (Section 2.2)", f"{int(h[q - 1])}")
        state_names = _names(self.state_names, "state_names", tuple(f"x{i}" for i in range(n)))
        mode_names = _names(self.mode_names, "mode_names", tuple(f"mode {q}" for q in range(1, Q + 1)))

        object.__setattr__(self, "f", f)
        object.__setattr__(self, "trigger", trigger)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "h", h)
        object.__setattr__(self, "state_names", state_names)
        object.__setattr__(self, "mode_names", mode_names)
        self._check_assumptions()
        qv = frozenset(q for q in range(1, Q + 1) if int(h[q - 1]) == q)
        v = frozenset(q for q in range(1, Q + 1) if q in qv or 1 + (q % Q) in qv)
        object.__setattr__(self, "_qv", qv)
        object.__setattr__(self, "_v", v)

    def _check_assumptions(self) -> None:
        f, trig, alpha, names = self.f, self.trigger, self.alpha, self.state_names
        Q, n = f.shape
        # Assumption 2.1: only the triggering component decreases, and it does strictly.
        for q in range(1, Q + 1):
            k = int(trig[q - 1])
            if not f[q - 1, k] < 0:
                raise ModelError(
                    f"Assumption 2.1 (mode {q})",
                    f"the triggering component {names[k]} to decrease, f_q[{names[k]}] < 0",
                    f"{f[q - 1, k]}",
                )
            for i in range(n):
                if i != k and f[q - 1, i] < 0:
                    raise ModelError(
                        f"Assumption 2.1 (mode {q})",
                        f"f_q[{names[i]}] >= 0 for the non-triggering component {names[i]}",
                        f"{f[q - 1, i]}",
                    )
        # Assumption 2.2, eq. (4): x0 is a timer with slope exactly -1 (triggering) or 0.
        for q in range(1, Q + 1):
            want = -1.0 if trig[q - 1] == 0 else 0.0
            if f[q - 1, 0] != want:
                role = "triggers the event (k_q = 1)" if want == -1.0 else "does not trigger (k_q != 1)"
                raise ModelError(
                    f"Assumption 2.2 (mode {q})",
                    f"f_q[{names[0]}] = {want:g} exactly, since the timer {names[0]} {role}",
                    f"{f[q - 1, 0]}",
                )
        # Assumption 2.3, eq. (5): a reset happens exactly before a timer (setup) mode.
        for q in range(1, Q + 1):
            nxt = self.successor(q)
            timer_next = trig[nxt - 1] == 0
            if (alpha[q - 1] > 0) != timer_next:
                if timer_next:
                    expected = f"alpha_q > 0, because mode sigma(q) = {nxt} is a timer (setup) mode"
                else:
                    expected = f"alpha_q = 0, because mode sigma(q) = {nxt} is not a timer (setup) mode"
                raise ModelError(f"Assumption 2.3 (mode {q})", expected, f"alpha_q = {alpha[q - 1]}")
        # Assumption 2.4, eq. (6): at least one setup of non-zero duration per cycle (no Zeno).
        if not alpha.sum() > 0:
            raise ModelError("Assumption 2.4", "sum of alpha_q > 0 (a non-zero setup in every cycle)", f"{alpha.tolist()}")
        # Assumption 2.5, eq. (7): a setup mode is followed by an operational mode.
        for q in range(1, Q + 1):
            nxt = self.successor(q)
            if trig[q - 1] == 0 and trig[nxt - 1] == 0:
                raise ModelError(
                    f"Assumption 2.5 (mode {q})",
                    f"the successor mode {nxt} of timer mode {q} not to be a timer mode (k_sigma(q) != 1)",
                    f"trigger of mode {nxt} = {names[0]}",
                )
        # Assumption 2.6: at least one visible mode.
        if not any(int(self.h[q - 1]) == q for q in range(1, Q + 1)):
            raise ModelError("Assumption 2.6", "at least one visible mode (h_q = q)", f"h = {self.h.tolist()}")

    # ------------------------------------------------------------------ sizes and names
    @property
    def n_modes(self) -> int:
        """Number of modes ``Q``."""
        return self.f.shape[0]

    @property
    def n_states(self) -> int:
        """Dimension ``N + 1`` of ``x`` (timer plus buffers)."""
        return self.f.shape[1]

    @property
    def n_buffers(self) -> int:
        """Number ``N`` of buffers / queues (the reduced state of Section 3.2)."""
        return self.f.shape[1] - 1

    @property
    def k(self) -> np.ndarray:
        """The paper's 1-based ``k_q`` (``trigger + 1``), for cross-checking against eq. (3)."""
        out = self.trigger + 1
        out.setflags(write=False)
        return out

    # ------------------------------------------------------------------ discrete structure
    def successor(self, q: int) -> int:
        """Cyclic successor ``sigma(q) = 1 + (q mod Q)``; implements eq. (1) of paper 003.

        Parameters
        ----------
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        int
            The next mode, ``1 ... Q``.
        """
        self._check_mode(q, "q")
        return 1 + (q % self.n_modes)

    def predecessor(self, q: int) -> int:
        """Inverse of :meth:`successor`, ``sigma^{-1}(q)``.

        Parameters
        ----------
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        int
            The previous mode, ``1 ... Q``.
        """
        self._check_mode(q, "q")
        return self.n_modes if q == 1 else q - 1

    def output(self, q: int) -> int:
        """Output ``y = h_q`` of mode ``q`` (eq. 3a): ``q`` if visible, else 0.

        Parameters
        ----------
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        int
            ``q`` in a visible mode, else 0.
        """
        self._check_mode(q, "q")
        return int(self.h[q - 1])

    @property
    def visible_modes(self) -> tuple[int, ...]:
        """``Q_v = {q : h_q = q}``, eq. (8) of paper 003."""
        return tuple(sorted(self._qv))

    @property
    def visible_event_modes(self) -> tuple[int, ...]:
        """``V = Q_v  U  {q : sigma(q) in Q_v}`` (Section 2.4), sorted as ``v_1 < ... < v_V``.

        The event that leaves mode ``q`` is visible exactly when ``q`` is in ``V``.
        """
        return tuple(sorted(self._v))

    def is_visible_event(self, q: int) -> bool:
        """Whether the event leaving mode ``q`` is visible (``q`` in ``V``, Section 2.4).

        Parameters
        ----------
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        bool
            Whether the event leaving ``q`` is visible.
        """
        self._check_mode(q, "q")
        return q in self._v

    def is_timer_mode(self, q: int) -> bool:
        """Whether mode ``q`` is ended by the timer ``x0`` (a setup mode, ``k_q = 1``).

        Parameters
        ----------
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        bool
            Whether ``q`` is a setup (timer) mode.
        """
        self._check_mode(q, "q")
        return int(self.trigger[q - 1]) == 0

    # ------------------------------------------------------------------ continuous dynamics
    def validate_state(self, x: ArrayLike, q: int, field_name: str = "x", mode_field: str = "q") -> np.ndarray:
        """Check that ``(x, q)`` is a state of the class and return ``x`` as a read-only array.

        ``x`` must have ``N + 1`` finite, non-negative entries (``x in R_+^{N+1}``, Lemma 2.11),
        must lie in the flow set of mode ``q`` (eq. 3a), and, if ``q`` is not a timer mode, must
        have ``x0 = 0``: in such a mode ``x0`` has slope 0 (Assumption 2.2) and Lemma 2.7 needs it
        to be 0 there, otherwise the next setup would last longer than ``alpha`` (Lemma 2.8).

        Parameters
        ----------
        x : (N+1,) array_like
            State ``(x0, x1, ..., xN)``: timer first, then the buffers.
        q : int
            Mode number in ``1..Q``.
        field_name : str, default "x"
            Name of ``x`` in the :class:`ModelError` raised on a bad state.
        mode_field : str, default "q"
            Name of ``q`` in the :class:`ModelError` raised on a bad mode.

        Returns
        -------
        (N+1,) ndarray
            ``x``, read-only.

        Raises
        ------
        ModelError
            If ``q`` is not a mode number or ``x`` breaks one of the conditions above.
        """
        self._check_mode(q, mode_field)
        arr = as_vector(x, field_name, self.n_states)
        bad = np.nonzero(arr < 0)[0]
        if bad.size:
            i = int(bad[0])
            raise ModelError(
                f"{field_name}[{self.state_names[i]}]", "a non-negative value (x in R_+^{N+1}, Lemma 2.11)", f"{arr[i]}"
            )
        if not self.is_timer_mode(q) and arr[0] != 0:
            raise ModelError(
                f"{field_name}[{self.state_names[0]}]",
                f"0 in mode {q}, which is not a timer mode (Lemma 2.7 / Assumption 2.2)",
                f"{arr[0]}",
            )
        return arr

    def mode_duration(self, x: ArrayLike, q: int) -> float:
        """Time left in mode ``q`` from state ``x``: ``x[k_q] / (-f_q[k_q])`` (flow of eq. 3a).

        For a timer mode entered at an event this is ``alpha`` of the preceding mode (Lemma 2.8).

        Parameters
        ----------
        x : (N+1,) array_like
            State in the flow set of mode ``q`` (checked by :meth:`validate_state`).
        q : int
            Mode number in ``1..Q``.

        Returns
        -------
        float
            Time until the event that ends mode ``q``.
        """
        arr = self.validate_state(x, q)
        return self._dwell(arr, q)

    def flow(self, x: ArrayLike, q: int, tau: float) -> np.ndarray:
        """State after flowing ``tau`` in mode ``q``: ``x + tau f_q`` (eq. 3a).

        ``tau`` must lie in ``[0, mode_duration(x, q)]`` (the flow set of mode ``q``).

        Parameters
        ----------
        x : (N+1,) array_like
            State in the flow set of mode ``q`` (checked by :meth:`validate_state`).
        q : int
            Mode number in ``1..Q``.
        tau : float
            Flow time, in ``[0, mode_duration(x, q)]``; at the upper end the trigger component is set
            to exactly 0.

        Returns
        -------
        (N+1,) ndarray
            The state after ``tau``.

        Raises
        ------
        ModelError
            If ``tau`` lies outside ``[0, mode_duration(x, q)]`` or the state is invalid.
        """
        arr = self.validate_state(x, q)
        tau_arr = as_vector(tau, "tau", 1)
        t = float(tau_arr[0])
        dwell = self._dwell(arr, q)
        if not 0 <= t <= dwell:
            raise ModelError("tau", f"0 <= tau <= {dwell} (the time left in mode {q})", f"{t}")
        out = arr + t * self.f[q - 1]
        if t == dwell:
            out[self.trigger[q - 1]] = 0.0
        out.setflags(write=False)
        return out

    def jump(self, x: ArrayLike, q: int) -> tuple[np.ndarray, int]:
        """Jump map (3b): ``x+ = x + alpha_q e_1``, ``q+ = sigma(q)``; ``x`` must satisfy ``x[k_q] = 0``.

        Parameters
        ----------
        x : (N+1,) array_like
            Pre-jump state, in the jump set ``x[k_q] = 0`` of mode ``q``.
        q : int
            Mode number in ``1..Q`` before the jump.

        Returns
        -------
        x_plus : (N+1,) ndarray
            Post-jump state (read-only).
        q_plus : int
            Next mode ``sigma(q)``.
        """
        arr = self.validate_state(x, q)
        k = int(self.trigger[q - 1])
        if arr[k] != 0:
            raise ModelError(
                f"x[{self.state_names[k]}]", f"0: the jump set of mode {q} is {self.state_names[k]} = 0 (eq. 3b)", f"{arr[k]}"
            )
        return self._jump(arr, q)

    def next_event(self, x: ArrayLike, q: int) -> NextEvent:
        """Flow to and jump through the next event from ``(x, q)`` (eqs. 3a-3b).

        Parameters
        ----------
        x : (N+1,) array_like
            State in the flow set of mode ``q`` (checked by :meth:`validate_state`).
        q : int
            Current mode number in ``1..Q``.

        Returns
        -------
        NextEvent
            Dwell time, pre- and post-jump states, ``q``, ``sigma(q)`` and visibility.
        """
        arr = self.validate_state(x, q)
        return self._next_event(arr, q)

    # ------------------------------------------------------------------ unchecked internals
    def _check_mode(self, q, field_name: str) -> None:
        if isinstance(q, bool) or not isinstance(q, (int, np.integer)):
            raise ModelError(field_name, f"an integer mode number in 1..{self.n_modes}", f"{q!r}")
        if not 1 <= int(q) <= self.n_modes:
            raise ModelError(field_name, f"a mode number in 1..{self.n_modes}", f"{q}")

    def _dwell(self, x: np.ndarray, q: int) -> float:
        k = int(self.trigger[q - 1])
        return float(x[k] / -self.f[q - 1, k])

    def _jump(self, x: np.ndarray, q: int) -> tuple[np.ndarray, int]:
        out = np.array(x, dtype=float)
        out[0] += self.alpha[q - 1]
        out.setflags(write=False)
        return out, 1 + (q % self.n_modes)

    def _next_event(self, x: np.ndarray, q: int) -> NextEvent:
        dwell = self._dwell(x, q)
        x_minus = x + dwell * self.f[q - 1]
        # Exactly on the jump set: rounding must not leave -1e-15 in a queue or a timer.
        x_minus[self.trigger[q - 1]] = 0.0
        x_minus.setflags(write=False)
        x_plus, nxt = self._jump(x_minus, q)
        return NextEvent(dwell, x_minus, x_plus, q, nxt, q in self._v)

    def __repr__(self) -> str:
        return (
            f"ConstantDriftSystem(Q={self.n_modes}, N={self.n_buffers}, k={self.k.tolist()}, "
            f"alpha={self.alpha.tolist()}, h={self.h.tolist()})"
        )


__all__ = ["ConstantDriftSystem", "NextEvent"]
