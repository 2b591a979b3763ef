"""Progress display for long work: a tqdm bar with units on a terminal (stderr), nothing otherwise.

Silent when ``enabled`` is false (``--json``) or stderr is not a terminal (tests, pipes, CI), so
machine-readable output is never interleaved with bars.  Each factory returns
``(callback, close)``; the callback is ``None`` when silent where callers accept ``None``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any


def _active(enabled: bool) -> bool:
    return bool(enabled) and sys.stderr.isatty()


def status_line(enabled: bool) -> tuple[Callable[[str], None], Callable[[], None]]:
    """``(update(message), close)``: one status line with the elapsed time (the report's sections)."""
    if not _active(enabled):
        return lambda msg: None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=None, file=sys.stderr, bar_format="{desc} [{elapsed}]", leave=False)

    def update(msg: str) -> None:
        bar.set_description_str(msg)
        bar.update(0)

    return update, bar.close


def counter_bar(enabled: bool, desc: str) -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """``(update(done, total), close)``: one bar (``None`` callback when silent)."""
    if not _active(enabled):
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=0, desc=desc, file=sys.stderr, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return update, bar.close


def phase_bars(enabled: bool) -> tuple[Callable[[str, str, int, int], None] | None, Callable[[], None]]:
    """``(progress(phase, unit, done, total), close)``: one bar per phase, with its unit.

    A new ``phase`` closes the previous bar and opens the next (Algorithm 3.1 in regions, the
    lookup tables in pieces, the observers' steps ...).
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
            state["bar"] = tqdm(total=total, desc=phase, unit=unit, file=sys.stderr, leave=False)
            state["phase"] = phase
        bar = state["bar"]
        bar.total = total
        bar.n = done
        bar.refresh()

    return progress, close
