"""Progress display for long work: a tqdm bar with units on a terminal (stderr), nothing otherwise.

Silent when ``enabled`` is false (``--json``) or stderr is not a terminal (tests, pipes, CI), so
machine-readable output is never interleaved with bars.  Each factory returns
``(callback, close)``; the callback is ``None`` when silent where callers accept ``None``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any


def _active(enabled: bool) -> bool:
    return bool(enabled) and sys.stderr.isatty()


#: Size of the terminal assumed when it reports none (a pseudo-terminal nobody sized): tqdm draws
#: nothing at width or height 0.
FALLBACK_COLUMNS, FALLBACK_LINES = 100, 24


def _shape() -> dict[str, int | None]:
    """tqdm's ``ncols``/``nrows``: ``None`` (follow the terminal) unless the terminal reports 0."""
    try:
        size = os.get_terminal_size(sys.stderr.fileno())
        columns, lines = size.columns, size.lines
    except (OSError, ValueError):
        columns = lines = 0
    return {"ncols": None if columns > 0 else FALLBACK_COLUMNS, "nrows": None if lines > 0 else FALLBACK_LINES}


def section_bar(enabled: bool, keys: list[str], desc: str = "report") -> tuple[Callable[[str], None], Callable[[], None]]:
    """``(update(message), close)``: a bar counting the report's sections (unit ``"section"``).

    ``update`` takes the report's progress messages: a section key advances the bar to that
    section, any other message (a step inside the section) is shown beside it.
    """
    if not _active(enabled):
        return lambda msg: None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=len(keys), desc=desc, unit="section", file=sys.stderr, leave=False, **_shape())
    order = {k: i for i, k in enumerate(keys)}

    def update(msg: str) -> None:
        if msg in order:
            bar.n = order[msg]
        bar.set_postfix_str(msg, refresh=False)
        bar.refresh()

    return update, bar.close


def counter_bar(enabled: bool, desc: str, unit: str = "it") -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """``(update(done, total), close)``: one bar counting ``unit`` (``None`` callback when silent).

    ``total=None`` when the amount of work is not known in advance (a count and a rate, no bar).
    """
    if not _active(enabled):
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=0, desc=desc, unit=unit, file=sys.stderr, leave=False, **_shape())

    def update(done: int, total: int | None) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return update, bar.close


class PhaseProgress:
    """A progress report in phases, each with its unit: ``progress(phase, unit, done, total)``.

    Long operations made of several phases (:func:`~hybobs_opt.regions.analyse_observability`:
    the mode enumeration, then the pair tests) report every phase to a ``PhaseProgress``, and only
    their main phase to a plain ``progress(done, total)`` callable (:func:`phase_callback`).

    Parameters
    ----------
    report : callable
        ``report(phase, unit, done, total)``: ``phase`` names the work ("pair tests"),
        ``unit`` what ``done`` and ``total`` count ("pair").

    See Also
    --------
    hybobs_opt.regions.analyse_observability : reports its phases to one.

    Examples
    --------
    >>> from hybobs_opt import PhaseProgress
    >>> progress = PhaseProgress(lambda phase, unit, done, total: print(f"{phase}: {done}/{total} {unit}s"))
    >>> progress("mode enumeration", "prefix", 3, 9)
    mode enumeration: 3/9 prefixs
    >>> pair_tests = progress.phase("pair tests", "pair")    # a plain (done, total) callback
    >>> pair_tests(5, 5)
    pair tests: 5/5 pairs
    """

    def __init__(self, report: Callable[[str, str, int, int], None]):
        if not callable(report):
            raise TypeError(f"report must be callable, got {type(report).__name__}")
        self._report = report

    def __call__(self, phase: str, unit: str, done: int, total: int) -> None:
        self._report(phase, unit, done, total)

    def phase(self, name: str, unit: str) -> Callable[[int, int], None]:
        """The ``(done, total)`` callback of one phase.

        Parameters
        ----------
        name : str
            The phase ("pair tests").
        unit : str
            What it counts ("pair").

        Returns
        -------
        callable
            ``callback(done, total)`` that reports ``(name, unit, done, total)``.
        """
        return lambda done, total: self._report(name, unit, done, total)


def phase_callback(progress, name: str, unit: str, main: bool = True) -> Callable[[int, int], None] | None:
    """The ``(done, total)`` callback of the phase ``name`` of a long operation.

    ``progress`` is ``None``, a :class:`PhaseProgress` (every phase reported with ``name`` and
    ``unit``) or a plain ``progress(done, total)`` callable, which receives the operation's
    ``main`` phase only.
    """
    if progress is None:
        return None
    if isinstance(progress, PhaseProgress):
        return progress.phase(name, unit)
    return progress if main else None


def phase_bars(enabled: bool) -> tuple[PhaseProgress | None, Callable[[], None]]:
    """``(progress(phase, unit, done, total), close)``: one bar per phase, with its unit.

    A new ``phase`` closes the previous bar and opens the next (Algorithm 3.1 in regions, the
    lookup tables in pieces, the observers' steps ...).  ``progress`` is a :class:`PhaseProgress`
    (``None`` when silent).
    """
    if not _active(enabled):
        return None, lambda: None
    from tqdm import tqdm

    state: dict[str, Any] = {"bar": None, "phase": None}

    def close() -> None:
        if state["bar"] is not None:
            state["bar"].close()
            state["bar"] = None

    def progress(phase: str, unit: str, done: int, total: int) -> None:
        if state["phase"] != phase:
            close()
            state["bar"] = tqdm(total=total, desc=phase, unit=unit, file=sys.stderr, leave=False, **_shape())
            state["phase"] = phase
        bar = state["bar"]
        bar.total = total
        bar.n = done
        bar.refresh()

    return PhaseProgress(progress), close
