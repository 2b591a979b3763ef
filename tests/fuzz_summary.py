"""Summary of the fuzz suite of issue 16: inputs tried per family and outcomes by class.

Run from the repository root::

    python -m tests.fuzz_summary                  # every family, each target's own number of inputs
    python -m tests.fuzz_summary --examples 50    # 50 inputs per target
    python -m tests.fuzz_summary --family cli --details

The families and strategies are those of ``tests/fuzz`` (the pytest suite runs the same targets
derandomised); here hypothesis draws from a fixed ``--seed``.  For each family the table lists the
inputs tried and the count of every outcome class, then one line PASS or FAIL against the
required outcome: no input may end in a bug class (``tests/fuzz/common.py``: anything but a
clear refusal, a certified verdict, a correct answer, a valid acceptance, a recovered observer run
or a one-line CLI error).  The exit status is 1 when a bug-class outcome occurred.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
import warnings
from collections import Counter

from .fuzz.common import GOOD_CLASSES, Tally, is_bug, run_target

#: family key -> module of tests/fuzz
FAMILIES = {
    "constructors": "test_constructors",
    "samples": "test_samples",
    "solvers": "test_solver_faults",
    "cli": "test_cli",
    "files": "test_saved_files",
    "hostile": "test_hostile_files",
}


def run_family(key: str, examples: int | None, seed: int, per_target: bool) -> tuple[object, Tally, list]:
    module = importlib.import_module(f"{__package__}.fuzz.{FAMILIES[key]}")
    family = module.FAMILY
    total, rows = Tally(), []
    for target in family.targets:
        t0 = time.perf_counter()
        tally = run_target(target, examples=examples, fixed_seed=seed)
        rows.append((target.name, tally, time.perf_counter() - t0))
        total.merge(tally)
        if per_target:
            print(f"  {target.name}: {tally.tried} inputs, {dict(tally.counts)} ({rows[-1][2]:.1f} s)", flush=True)
    return family, total, rows


def _table(results) -> str:
    classes = sorted({c for _, tally, _ in results for c in tally.counts},
                     key=lambda c: (is_bug(c), c))
    head = ["family", "inputs"] + classes
    lines = [[fam.name, str(tally.tried)] + [str(tally.counts.get(c, 0)) for c in classes] for fam, tally, _ in results]
    widths = [max(len(r[i]) for r in [head] + lines) for i in range(len(head))]
    fmt = lambda r: "  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(r, widths)))  # noqa: E731
    sep = "  ".join("-" * w for w in widths)
    return "\n".join([fmt(head), sep] + [fmt(r) for r in lines])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz_summary", description=__doc__.split("\n\n")[0])
    p.add_argument("--family", action="append", choices=sorted(FAMILIES), help="only these families (repeatable)")
    p.add_argument("--examples", type=int, default=None, metavar="N",
                   help="inputs per target (default: each target's own, as in the pytest run)")
    p.add_argument("--seed", type=int, default=16, help="hypothesis seed (default 16)")
    p.add_argument("--details", action="store_true", help="list every input that ended in a bug class")
    p.add_argument("--quiet", action="store_true", help="no per-target lines")
    args = p.parse_args(argv)
    if args.examples is not None and args.examples < 1:
        p.error("--examples must be at least 1")
    warnings.simplefilter("ignore")  # the outcomes are classified; warnings the library prints are not the table
    results = []
    t0 = time.perf_counter()
    for key in args.family or list(FAMILIES):
        if not args.quiet:
            print(f"{key}:", flush=True)
        family, tally, rows = run_family(key, args.examples, args.seed, not args.quiet)
        results.append((family, tally, rows))
    print()
    print(_table([(f, t, r) for f, t, r in results]))
    print()
    bugs = 0
    for family, tally, rows in results:
        n_bugs = sum(v for c, v in tally.counts.items() if is_bug(c))
        bugs += n_bugs
        verdict = "PASS" if n_bugs == 0 else "FAIL"
        classes = Counter({c: v for c, v in tally.counts.items() if is_bug(c)})
        why = "" if not n_bugs else ": " + ", ".join(f"{v} {c}" for c, v in classes.most_common())
        print(f"{verdict}  {family.name} ({tally.tried} inputs; required: {family.required}){why}")
        if n_bugs:
            failing = [name for name, t, _ in rows if t.bugs]
            print(f"      targets with bugs: {', '.join(failing)}")
        if args.details:
            for outcome, detail in tally.bugs:
                print(f"      {outcome}: {detail[:300]}")
    good = ", ".join(sorted(GOOD_CLASSES))
    print(f"\n{sum(t.tried for _, t, _ in results)} inputs in {time.perf_counter() - t0:.0f} s; classes that satisfy the "
          f"issue: {good}; every other class is a bug.")
    return 1 if bugs else 0


if __name__ == "__main__":
    sys.exit(main())
