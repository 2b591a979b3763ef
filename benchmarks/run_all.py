"""Run every benchmark module of this folder: ``python -m benchmarks.run_all [--quick]``.

Each ``benchmarks/bench_*.py`` module exposes ``main(argv) -> int`` and writes its own JSON into
``benchmarks/results/`` (``results/quick/`` with ``--quick``); arguments are passed through.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import time
from pathlib import Path


def bench_modules() -> list[str]:
    here = Path(__file__).resolve().parent
    return sorted(f"{__package__ or 'benchmarks'}.{m.name}" for m in pkgutil.iter_modules([str(here)])
                  if m.name.startswith("bench_"))


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    failed = []
    for name in bench_modules():
        print(f"[run_all] {name} {' '.join(argv)}", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        try:
            code = importlib.import_module(name).main(argv)
        except Exception as exc:  # one broken benchmark must not hide the others
            print(f"[run_all] {name} failed: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
            code = 1
        print(f"[run_all] {name} done in {time.perf_counter() - t0:.0f} s (exit {code})", file=sys.stderr, flush=True)
        if code:
            failed.append(name)
    if failed:
        print(f"[run_all] failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
