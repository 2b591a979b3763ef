"""``hybobs cache [info|clear]``: the cache of analyses and lookup tables (:mod:`hybobs_opt.cache`)."""

from __future__ import annotations

import argparse

from ._common import print_json

HELP = "show (info) or empty (clear) the cache of analyses and lookup tables"

#: The actions of ``hybobs cache``.
ACTIONS = ("info", "clear")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", nargs="?", default="info", choices=ACTIONS,
                   help="info: where the cache is and what it holds (default); clear: delete every entry")
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    from .._environment import CACHE_DIR_ENV
    from ..cache import ResultCache

    cache = ResultCache()
    if args.action == "clear":
        files, size = cache.clear()
        out = {"directory": str(cache.directory), "removed_files": files, "removed_bytes": size}
        if args.json:
            print_json(out)
        else:
            print(f"removed {files} cache entr{'y' if files == 1 else 'ies'} ({_size(size)}) from {cache.directory}")
        return 0
    entries = cache.entries()
    kinds: dict[str, dict[str, int]] = {}
    for e in entries:
        k = kinds.setdefault(e["kind"], {"files": 0, "bytes": 0})
        k["files"] += 1
        k["bytes"] += e["bytes"]
    out = {"directory": str(cache.directory), "exists": cache.directory.is_dir(), "n_entries": len(entries),
           "bytes": sum(e["bytes"] for e in entries), "kinds": kinds, "entries": entries}
    if args.json:
        print_json(out)
        return 0
    print(f"cache directory: {cache.directory} (set {CACHE_DIR_ENV} to move it)")
    print(f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}, {_size(out['bytes'])}")
    for kind, k in sorted(kinds.items()):
        print(f"  {kind}: {k['files']} ({_size(k['bytes'])})")
    return 0


def _size(n: int) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"  # pragma: no cover
