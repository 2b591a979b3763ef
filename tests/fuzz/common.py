"""Outcome classes, the classifier helpers and the runner shared by the fuzz families.

Every input a family tries ends in one outcome class.  The classes that satisfy issue 16 are

==============================  ==================================================================
``ModelError``                  a clear refusal of bad input (a file refusal must name the file)
``SolverError``                 a solver fault reported as such
``InfeasibleError-certified``   infeasible, with a certificate whose ``verify()`` is true
``correct-answer``              a solver fault absorbed by a fallback: the answer is still right
``accepted-valid``              the input was valid after all (a corruption that changed nothing)
``observer-ok``                 bad samples: no exception, no wrong ``observable``, recovered
``cli-exit-2-one-line``         exit 2, one stderr line (``--json``: one JSON object with error)
==============================  ==================================================================

and every other class is a bug: ``accepted-garbage``, ``other-exception:<type>``,
``wrong-flagged-good``, ``not-recovered``, ``wrong-answer``, ``InfeasibleError-uncertified``,
``ModelError-not-naming-file``, ``cli-traceback``, ``cli-exit-0-on-bad-input``,
``cli-exit-2-malformed``, ``cli-exit-<code>``.
"""

from __future__ import annotations

import warnings
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from hypothesis import HealthCheck, Phase, example, given, seed, settings
from hypothesis import strategies as st

from hybobs_opt.errors import InfeasibleError, ModelError, SolverError

# ---------------------------------------------------------------------------------- outcome classes

MODEL_ERROR = "ModelError"
SOLVER_ERROR = "SolverError"
INFEASIBLE_CERTIFIED = "InfeasibleError-certified"
CORRECT = "correct-answer"
ACCEPTED_VALID = "accepted-valid"
OBSERVER_OK = "observer-ok"
CLI_OK = "cli-exit-2-one-line"

ACCEPTED_GARBAGE = "accepted-garbage"
WRONG_FLAGGED_GOOD = "wrong-flagged-good"
NOT_RECOVERED = "not-recovered"
WRONG_ANSWER = "wrong-answer"
INFEASIBLE_UNCERTIFIED = "InfeasibleError-uncertified"
MODEL_ERROR_UNNAMED = "ModelError-not-naming-file"
CLI_TRACEBACK = "cli-traceback"
CLI_EXIT0 = "cli-exit-0-on-bad-input"
CLI_MALFORMED = "cli-exit-2-malformed"

GOOD_CLASSES = frozenset({MODEL_ERROR, SOLVER_ERROR, INFEASIBLE_CERTIFIED, CORRECT, ACCEPTED_VALID, OBSERVER_OK, CLI_OK})


def is_bug(outcome: str) -> bool:
    """Every class outside :data:`GOOD_CLASSES` is a defect of the library."""
    return outcome not in GOOD_CLASSES


def other(exc: BaseException) -> str:
    return f"other-exception:{type(exc).__name__}"


def exception_outcome(exc: BaseException) -> str:
    """The class of an exception raised on bad input or a solver fault."""
    if isinstance(exc, ModelError):
        return MODEL_ERROR
    if isinstance(exc, SolverError):
        return SOLVER_ERROR
    if isinstance(exc, InfeasibleError):
        cert = getattr(exc, "certificate", None)
        try:
            ok = cert is not None and bool(cert.verify())
        except Exception:  # a certificate that cannot even be checked does not verify
            ok = False
        return INFEASIBLE_CERTIFIED if ok else INFEASIBLE_UNCERTIFIED
    return other(exc)


class strict_warnings(warnings.catch_warnings):
    """The suite's warning filters inside and outside pytest alike: a RuntimeWarning from
    hybobs_opt is an error (pyproject.toml), and so is numpy's ComplexWarning (a silent
    coercion of bad input)."""

    def __enter__(self):
        out = super().__enter__()
        import numpy as np

        warnings.filterwarnings("error", category=RuntimeWarning, module=r"hybobs_opt\..*")
        warnings.filterwarnings("error", category=np.exceptions.ComplexWarning)
        return out


# ---------------------------------------------------------------------------------- targets and runs

@dataclass
class Target:
    """One thing a family fuzzes: a strategy of inputs and ``try_one(value) -> (outcome, detail)``.

    ``examples`` is the number of inputs the pytest run tries (the summary may try more), on top
    of the ``explicit`` inputs, which every run tries first.
    """

    name: str
    strategy: st.SearchStrategy
    try_one: Callable[[Any], tuple[str, str]]
    examples: int = 10
    explicit: tuple = ()


@dataclass
class Family:
    name: str
    required: str
    targets: list[Target]


@dataclass
class Tally:
    """Outcomes of the inputs tried on one target (or a whole family)."""

    counts: Counter = field(default_factory=Counter)
    bugs: list[tuple[str, str]] = field(default_factory=list)

    @property
    def tried(self) -> int:
        return sum(self.counts.values())

    def add(self, outcome: str, detail: str) -> None:
        self.counts[outcome] += 1
        if is_bug(outcome):
            self.bugs.append((outcome, detail))

    def merge(self, other: "Tally") -> None:
        self.counts.update(other.counts)
        self.bugs.extend(other.bugs)


def settings_for(examples: int, derandomize: bool = True) -> settings:
    """Derandomised (CI-stable), no example database, no deadline, no shrinking: an input that
    fails is recorded, not minimised, so the run takes ``examples`` tries and no more."""
    return settings(max_examples=examples, derandomize=derandomize, database=None, deadline=None,
                    phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck),
                    print_blob=False, report_multiple_bugs=False)


def run_target(target: Target, examples: int | None = None, fixed_seed: int | None = None) -> Tally:
    """Try ``examples`` inputs of ``target`` (derandomised, or from ``fixed_seed``); tally them."""
    tally = Tally()
    n = target.examples if examples is None else examples

    def body(value):
        try:
            outcome, detail = target.try_one(value)
        except Exception as exc:  # the harness itself must not hide an input: count it as a bug
            outcome, detail = f"harness-error:{type(exc).__name__}", f"{value!r}: {exc}"
        tally.add(outcome, f"{target.name}: {detail}")

    test = given(target.strategy)(body)
    for value in reversed(target.explicit):
        test = example(value)(test)
    if fixed_seed is None:
        test = settings_for(n)(test)
    else:
        test = seed(fixed_seed)(settings_for(n, derandomize=False)(test))
    test()
    return tally


def assert_no_bugs(tally: Tally, limit: int = 8) -> None:
    """Fail with the first few buggy inputs and the counts of every class."""
    if tally.bugs:
        lines = [f"  {o}: {d[:400]}" for o, d in tally.bugs[:limit]]
        raise AssertionError(f"{len(tally.bugs)} of {tally.tried} inputs are bugs; outcomes {dict(tally.counts)}\n"
                             + "\n".join(lines))


def describe(value: Any, limit: int = 160) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def first(items: Iterable, default=None):
    return next(iter(items), default)
