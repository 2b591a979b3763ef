"""Conversions between python-control's ``StateSpace`` and the linear parts of PWA modes and hybrid locations.

A ``control.StateSpace`` holds ``(A, B, C, D)`` and a timebase ``dt`` (``0`` continuous,
``> 0`` or ``True`` discrete); it has no affine terms and no region.  So a mode of eq. (1),
paper 002 (``x+ = A x + B u + a``, ``y = C x + D u + c`` on the guard ``Q_i``), is built from an
ss object plus its guard and, when non-zero, ``a`` and ``c`` given as keyword arguments; the way
back returns the linear part only, and refuses a mode with non-zero affine terms unless the
caller asks to drop them (``drop_affine=True``), since a ``StateSpace`` silently missing them
would simulate another system.

The methods that use this module are :meth:`PWAMode.from_control <hybobs_opt.systems.pwa.PWAMode.from_control>`,
:meth:`PWAMode.to_control <hybobs_opt.systems.pwa.PWAMode.to_control>`, the same two of
:class:`~hybobs_opt.systems.pwa.PWASystem` and of :class:`~hybobs_opt.systems.hybrid.Location`.
python-control is imported on the first call (the ``interop`` extra).

Continuous-time ss objects are refused where a discrete-time mode is built: discretise first
(``control.c2d(sys, Ts, "zoh")``; an affine term needs the same hold, which is why this module
does not do it for you).  The names python-control gives by default (``x[0]``, ``u[0]``,
``y[0]``) are not carried over; names the user gave are.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._optional import require
from ..errors import ModelError

#: python-control's generated signal labels (``x[0]``, ``u[1]``, ``y[2]``): not names the user gave.
_DEFAULT_LABEL = re.compile(r"^[xuy]\[\d+\]$")


def control_module():
    """python-control, or the ModelError naming the ``interop`` extra."""
    return require("control", "convert to and from python-control state-space systems")


def check_state_space(sys: Any, field: str, discrete: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Any]:
    """``(A, B, C, D, dt)`` of a python-control ``StateSpace`` of the required timebase.

    Parameters
    ----------
    sys : control.StateSpace
        The system.
    field : str
        Name of the argument (for errors).
    discrete : bool
        True: a discrete-time system is required (``dt > 0`` or ``dt is True``); False: a
        continuous-time one (``dt == 0``).

    Returns
    -------
    tuple
        Copies of ``A, B, C, D`` as float arrays and ``dt``.

    Raises
    ------
    ModelError
        ``sys`` is not a ``StateSpace`` or has the other timebase (or an unspecified one, ``dt=None``).
    """
    control = control_module()
    if not isinstance(sys, control.StateSpace):
        hint = " (convert it with control.ss(sys))" if isinstance(sys, control.InputOutputSystem) else ""
        raise ModelError(field, f"a control.StateSpace{hint}", type(sys).__name__)
    dt = sys.dt
    if discrete:
        if dt is None or dt is False or (dt is not True and not (isinstance(dt, (int, float)) and dt > 0)):
            raise ModelError(f"{field}.dt", "a discrete-time system (dt > 0 or dt=True); discretise a continuous one "
                             "first, e.g. control.c2d(sys, Ts, 'zoh')", "dt=None (unspecified timebase)" if dt is None
                             else f"dt={dt!r} (continuous time)")
    elif dt is None or dt is True or dt != 0:
        raise ModelError(f"{field}.dt", "a continuous-time system (dt=0) for the flow x' = A x + B u + E",
                         "dt=None (unspecified timebase)" if dt is None else f"dt={dt!r} (discrete time)")
    return (np.array(sys.A, dtype=float), np.array(sys.B, dtype=float), np.array(sys.C, dtype=float),
            np.array(sys.D, dtype=float), dt)


#: python-control's generated system names (``sys[3]``, also with a suffix such as ``$copy``).
_DEFAULT_NAME = re.compile(r"^sys\[\d+\]")


def given_name(sys: Any) -> str:
    """The ss object's name when the user gave it, else ``""``."""
    name = getattr(sys, "name", "") or ""
    return "" if _DEFAULT_NAME.match(name) else str(name)


def given_labels(labels: Sequence[str]) -> tuple[str, ...]:
    """The labels when the user gave them, else ``()`` (python-control's ``x[0]``, ... are not names)."""
    labels = tuple(labels)
    return () if all(_DEFAULT_LABEL.match(lb) for lb in labels) else labels


def sampling_time(dts: Sequence[Any], field: str) -> float | None:
    """The common sampling period of discrete-time ss objects: ``None`` when every ``dt`` is ``True``.

    Raises
    ------
    ModelError
        Two systems have different numeric sampling periods.
    """
    numeric = [float(dt) for dt in dts if dt is not True]
    if not numeric:
        return None
    if any(dt != numeric[0] for dt in numeric):
        raise ModelError(field, "systems with one sampling period (dt) or dt=True", f"dt = {sorted(set(numeric))}")
    return numeric[0]


def make_state_space(A, B, C, D, dt, *, field: str, name: str = "", states=(), inputs=(), outputs=()):
    """A python-control ``StateSpace`` with the given labels (python-control's defaults where empty).

    Raises
    ------
    ModelError
        The system has no input (python-control 0.10 cannot build a ``StateSpace`` with ``m = 0``:
        it reshapes the empty ``D`` to ``(0, 0)``).
    """
    control = control_module()
    if B.shape[1] == 0:
        raise ModelError(field, "a system with at least one input (python-control 0.10 cannot hold a StateSpace "
                         "without inputs)", "m = 0")
    kwargs: dict[str, Any] = {}
    if name:
        kwargs["name"] = name
    for key, labels in (("states", states), ("inputs", inputs), ("outputs", outputs)):
        if labels:
            kwargs[key] = list(labels)
    return control.ss(np.array(A, dtype=float), np.array(B, dtype=float), np.array(C, dtype=float),
                      np.array(D, dtype=float), dt, **kwargs)


def affine_or_refuse(terms: Sequence[tuple[str, np.ndarray | None]], drop_affine: bool, field: str) -> None:
    """Refuse non-zero affine terms (a ``StateSpace`` cannot hold them) unless ``drop_affine``.

    Raises
    ------
    ModelError
        Naming the first non-zero term.
    """
    if drop_affine:
        return
    for key, value in terms:
        if value is not None and np.any(np.asarray(value) != 0):
            raise ModelError(f"{field}.{key}", "zero affine terms (a control.StateSpace has none); pass "
                             "drop_affine=True to convert the linear part and keep the affine terms yourself",
                             f"{np.asarray(value).tolist()}")
