"""Named resource limits: requests beyond them are refused before any memory is allocated.

Like :mod:`hybobs_opt.tolerances` and :mod:`hybobs_opt.defaults`, every limit is defined here
with the reason for its size.  A limit is far above what any study or sensible use needs; it
exists so that a typing error (``t_final = 1e12`` instead of ``1e2``) is a
:class:`~hybobs_opt.errors.ModelError` naming the request and the limit, not a ``MemoryError`` (or
a machine swapping) minutes later.  The messages name the function parameter; the CLI translates
it into its option.  Defaults (such as the horizon a command uses when none is given) are in
:mod:`hybobs_opt.defaults`.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from .errors import ModelError

#: Samples of one simulated trace (the time grid of a run).  A trace keeps ``t``, the states, the
#: mode, the inputs and the outputs of every sample as float64 (about 100 bytes per sample for the
#: examples, plus the solver's dense output while it runs): 10^7 samples are about 1 GB, the most a
#: workstation holds comfortably.  The papers' scenarios have at most 5 001 samples.
MAX_SAMPLES: int = 10_000_000

#: Observation horizon ``T`` (samples of a window) of the regions, lookup and moving-horizon
#: observers.  The enumeration visits up to ``n_modes ** T`` mode sequences and each LP has ``O(T)``
#: rows and columns: beyond 100 steps nothing finishes (the papers use ``T <= 5``).
MAX_HORIZON: int = 100


#: Points of a 2-D grid (a region cut ``NX x NY``): each is a membership test over every region
#: and three floats per state; 10^6 points is a 1000 x 1000 image, finer than any figure shows.
MAX_GRID_POINTS: int = 1_000_000

#: Bound on an observer gain ``||L||_2`` (model units).  The LMIs take it squared and scaled
#: (``gamma = (bound / scale)^2``); above 10^12 the square exceeds the relative accuracy of the conic
#: solvers by far (it constrains nothing any more), and near 10^154 it overflows a double.
MAX_GAIN_BOUND: float = 1e12

#: Bytes of the ``static const`` tables of an exported lookup observer (``hybobs_opt.observers.c_export``,
#: ``hybobs export``).  Model (17) at T = 5 needs 14 MB in double precision, already beyond the flash of
#: most engine controllers; the C source is about 2.5 times larger than its tables and a compiler
#: needs several times that in memory, so beyond 256 MiB nothing useful compiles.
MAX_EXPORT_TABLE_BYTES: int = 256 * 1024 * 1024

#: Bytes the prefix tree of the moving-horizon solver ``"sequences"`` (:mod:`hybobs_opt.mhe.sequence_lp`)
#: may hold: its nodes' matrices and their LP models, charged before each is made.  Model (16) at
#: T = 10 on noisy data holds well under 100 MB over a run; a whole tree of 3^10 sequences built
#: eagerly took 21 GB.  1 GiB leaves room for a second observer on a workstation.
#: ``MHESettings(solver_options={"memory_budget": bytes})`` sets another budget per observer.
MAX_SEQUENCE_TREE_BYTES: int = 1 << 30

#: Local worker processes per core: each forked worker holds a copy of the package and the
#: problem; more than a few per core only adds start-up time and memory.
MAX_WORKERS_PER_CORE: int = 4


def sample_count(t_final: float, dt: float, t0: float = 0.0) -> float:
    """Number of samples of the grid ``t0, t0 + dt, ... <= t_final`` (a float: may be astronomically large)."""
    return math.floor((t_final - t0) / dt + 1e-9) + 1.0


def check_samples(n: float, field: str, detail: str = "") -> None:
    """``ModelError(field)`` if a run of ``n`` samples exceeds :data:`MAX_SAMPLES`.

    ``detail`` says how ``n`` came about (e.g. ``"t_final = 1e+12 s at dt = 0.001 s"``).
    """
    if n > MAX_SAMPLES:
        asked = f"{n:.4g}" if n >= 1e15 else f"{int(n):,}"
        raise ModelError(field, f"a run of at most {MAX_SAMPLES:,} samples (hybobs_opt.limits.MAX_SAMPLES, about 1 GB)",
                         f"{asked} samples" + (f" ({detail})" if detail else ""))


def check_horizon_limit(T: int, field: str = "horizon T") -> None:
    """``ModelError(field)`` if the horizon ``T`` exceeds :data:`MAX_HORIZON`."""
    if T > MAX_HORIZON:
        raise ModelError(field, f"a horizon of at most {MAX_HORIZON} samples (hybobs_opt.limits.MAX_HORIZON: up to "
                         "n_modes ** T mode sequences to enumerate)", f"T = {T}")


def max_workers() -> int:
    """The most local worker processes accepted: :data:`MAX_WORKERS_PER_CORE` per core."""
    import os

    return MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)

#: Largest model file read, in bytes (checked before parsing): the largest shipped model is a
#: few kilobytes; a model of a thousand modes fits in a few megabytes.
MAX_MODEL_FILE_BYTES: int = 16 * 1024 * 1024

#: Most YAML aliases (``*name``) a model file may use.  An alias is a reference, cheap to parse and
#: expensive to expand: 9 levels of nested aliases in 820 bytes made a walk of the document take
#: 3.6 GB; a model needs few, if any.
MAX_YAML_ALIASES: int = 64

#: Largest predicted number of pair LPs of Algorithm 3.1 run without being asked for more
#: (:func:`~hybobs_opt.regions.predict_analysis_cost`; ``analyse_observability(...,
#: max_pair_lps=N)``, CLI ``--max-lps N``): about 35 minutes at the 0.4 ms per LP measured here.
MAX_PREDICTED_PAIR_LPS: int = 5_000_000

_PAIR_LP_BUDGET: ContextVar[int] = ContextVar("hybobs_pair_lp_budget", default=MAX_PREDICTED_PAIR_LPS)


def pair_lp_budget() -> int:
    """The budget of predicted pair LPs in force (:func:`raised_pair_lp_budget` sets it)."""
    return _PAIR_LP_BUDGET.get()


@contextmanager
def raised_pair_lp_budget(n: int | None) -> Iterator[None]:
    """Inside the block, analyses predicted up to ``n`` pair LPs run (``None``: unchanged)."""
    token = _PAIR_LP_BUDGET.set(int(n)) if n is not None else None
    try:
        yield
    finally:
        if token is not None:
            _PAIR_LP_BUDGET.reset(token)
