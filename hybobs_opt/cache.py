"""A cache of analyses and lookup tables, keyed by the system's fingerprint.

Algorithm 3.1 of paper 002, the lookup observer's tables of ``B~_T`` and the exact labels of a
scenario's windows depend only on the system, the horizon and the code that computed them, so the
command line keeps them between runs: a second ``hybobs observe powertrain5`` loads them instead
of solving the LPs again.  The library computes afresh unless a cache is made active
(:func:`use_cache`); the CLI activates one unless ``--no-cache`` (or ``HYBOBS_NO_CACHE=1``) is given,
and ``hybobs cache clear`` empties it.

Where
    ``$HYBOBS_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/hybobs_opt``, else
    ``~/.cache/hybobs_opt`` (:func:`default_cache_dir`).
Key
    SHA-256 of the canonical JSON of the entry's kind, the system's fingerprint
    (:func:`~hybobs_opt.systems.fingerprint.system_fingerprint`), its parameters (horizon, the
    tolerances, a digest of the inputs), the package version and a digest of the package's
    source files (:func:`code_digest`): an edited checkout never reads an entry an older code
    wrote.
Entries
    An analysis is a sealed regions file (:func:`~hybobs_opt.regions.save_analysis`), read back
    by :func:`~hybobs_opt.regions.load_analysis`, which checks its checksum, its fingerprint
    against the system and its content against the mode sequences.  Arrays are an ``.npz``
    (read with ``allow_pickle=False``) holding the key and a SHA-256 of every array.
Trust
    A plain checksum anyone can recompute: every entry also has a ``.mac`` file, the HMAC-SHA256
    of its bytes under a key kept in the directory (``.hybobs-cache-key``, 32 random bytes, mode
    0600), and an entry without a valid one is never read as a result (it is recomputed and
    replaced).  The directory is used only when this user owns it and nobody else can write to it
    (:func:`hybobs_opt._trust.untrusted_directory`); ``clear`` removes only the entries it names
    (``KIND-<32 hex>.json|.npz``, their ``.mac`` and its temporary files).
Failures
    An entry that is unreadable, corrupted or for another key is refused and recomputed (and
    rewritten); a directory that cannot be written is reported once and the run goes on without
    caching.  A cache never changes an answer, only how long it takes.

Every lookup, store and refusal is an event (:attr:`ResultCache.events`) passed to ``log`` (the
CLI prints it on stderr, and lists the events under ``"cache"`` in its ``--json`` summary).
"""

from __future__ import annotations

import hashlib
import hmac
import io
import json
import os
import re
import secrets
import time
import zipfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ._environment import CACHE_DIR_ENV, cache_root
from .errors import ModelError

#: Layout version of the entries (part of every key).
CACHE_FORMAT = 1
#: The key of the entries' MACs, in the cache directory.
KEY_FILE = ".hybobs-cache-key"
#: The names of the toolbox's entries and of its temporary files (``clear`` removes nothing else).
_ENTRY = re.compile(r"[a-z][a-z0-9-]*-[0-9a-f]{32}\.(json|npz)")
_OWN_FILE = re.compile(r"[a-z][a-z0-9-]*-[0-9a-f]{32}\.(json|npz)(\.mac)?(\.tmp[0-9]+(\.npz|\.mac)?)?")

__all__ = ["ResultCache", "active_cache", "analysis_key_parts", "array_digest",
           "cached_analysis", "code_digest", "default_cache_dir", "use_cache"]


def default_cache_dir() -> Path:
    """``$HYBOBS_CACHE_DIR``, else ``$XDG_CACHE_HOME/hybobs_opt``, else ``~/.cache/hybobs_opt``
    (:func:`hybobs_opt._environment.cache_root`)."""
    return cache_root()


@lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 over the package's Python sources (path and content), computed once per process."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def array_digest(arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 over the names, dtypes, shapes and bytes of ``arrays`` (the checksum of an entry,
    and the key part of a result computed from arrays)."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


class ResultCache:
    """A directory of cached results (see the module docstring).

    Parameters
    ----------
    directory : path-like, optional
        Where the entries live (default :func:`default_cache_dir`).  Created when the first
        entry is written.
    log : callable, optional
        ``log(message)`` for every event (a hit, a store, a refused entry, an unwritable
        directory).

    Attributes
    ----------
    events : list of dict
        One record per event: ``kind``, ``what``, ``outcome`` (``"hit"``, ``"stored"``,
        ``"refused"``, ``"not stored"``), ``path``, ``seconds`` and, when refused, ``reason``.

    See Also
    --------
    use_cache : make a cache the active one.
    cached_analysis : an observability analysis through the active cache.

    Examples
    --------
    A cache in a directory of its own; ``log`` receives one line per load or store:

    >>> import tempfile
    >>> from hybobs_opt import ResultCache, cached_analysis, get_example, use_cache
    >>> cache = ResultCache(tempfile.mkdtemp(), log=print)
    >>> plant = get_example("powertrain3").build()
    >>> with use_cache(cache):
    ...     analysis = cached_analysis(plant, 3)
    ...     again = cached_analysis(plant, 3)
    observability analysis of 'powertrain3 (tau=0.08333)' (T = 3): computed and stored in the cache (...)
    observability analysis of 'powertrain3 (tau=0.08333)' (T = 3): loaded from the cache (...)
    >>> [entry["kind"] for entry in cache.entries()]
    ['analysis']
    >>> n_files, n_bytes = cache.clear()            # empties the directory
    """

    def __init__(self, directory: str | os.PathLike | None = None, log: Callable[[str], None] | None = None):
        if log is not None and not callable(log):
            raise ModelError("log", "None or a callable log(message)", type(log).__name__)
        self.directory = Path(directory).expanduser() if directory is not None else default_cache_dir()
        self.log = log
        self.events: list[dict[str, Any]] = []
        self._unwritable = False
        self._key: bytes | None = None
        self._distrust: str | None = None

    # ------------------------------------------------------------------ keys and events
    def key(self, kind: str, parts: Mapping[str, Any]) -> str:
        """SHA-256 of ``kind``, ``parts``, the package version and :func:`code_digest`.

        Parameters
        ----------
        kind : str
            The kind of entry (``"analysis"``, ``"lookup-pieces"``, ``"exact-labels"``).
        parts : mapping
            What the entry depends on besides the code (JSON-serialisable).

        Returns
        -------
        str
            64 hexadecimal digits naming the entry.
        """
        from . import __version__

        body = {"kind": kind, "parts": dict(parts), "version": __version__, "code": code_digest(), "format": CACHE_FORMAT}
        return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"), default=str).encode()).hexdigest()

    def path(self, kind: str, key: str, suffix: str) -> Path:
        """The file of the entry ``kind``/``key``.

        Parameters
        ----------
        kind : str
            The kind of entry (the file name's prefix).
        key : str
            Its :meth:`key` (the first 32 hex digits name the file).
        suffix : str
            ``".json"`` (an analysis) or ``".npz"`` (arrays).

        Returns
        -------
        Path
            Where the entry's file is (or would be) in the cache directory.
        """
        return self.directory / f"{kind}-{key[:32]}{suffix}"

    def _event(self, kind: str, what: str, outcome: str, path: Path, seconds: float, reason: str | None = None) -> None:
        record = {"kind": kind, "what": what, "outcome": outcome, "path": str(path), "seconds": round(seconds, 4)}
        if reason:
            record["reason"] = reason
        self.events.append(record)
        if self.log is not None:
            verb = {"hit": "loaded from the cache", "stored": "computed and stored in the cache",
                    "refused": "cache entry refused, recomputed", "not stored": "computed (cache not writable)"}[outcome]
            tail = f": {reason}" if reason else ""
            self.log(f"{what}: {verb} ({path}, {seconds:.2f} s){tail}")

    def _trusted(self) -> bool:
        """Whether the directory may be read and written (this user's, writable by nobody else)."""
        from ._trust import untrusted_directory

        if self._distrust is None:
            why = untrusted_directory(self.directory)
            self._distrust = why or ""
            if why and self.log is not None:
                self.log(f"cache directory {self.directory} {why}: not used (set {CACHE_DIR_ENV} to a directory of "
                         "your own, or pass --no-cache)")
        return not self._distrust

    def _mac_key(self, create: bool) -> bytes | None:
        """The key of the entries' MACs (created on the first store); ``None`` when there is none
        or it is not this user's private file."""
        if self._key is not None:
            return self._key
        path = self.directory / KEY_FILE
        try:
            if create and not path.exists():
                fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
                with os.fdopen(fd, "wb") as fh:
                    fh.write(secrets.token_bytes(32))
            st = os.lstat(path)
            if not os.path.isfile(path) or os.path.islink(path) or (hasattr(os, "getuid") and st.st_uid != os.getuid()) \
                    or st.st_mode & 0o077:
                return None
            key = path.read_bytes()
        except OSError:
            return None
        if len(key) != 32:
            return None
        self._key = key
        return key

    def _verified_bytes(self, path: Path) -> bytes:
        """The bytes of the entry at ``path`` when its ``.mac`` proves this toolbox wrote them."""
        key = self._mac_key(create=False)
        if key is None:
            raise ValueError("no MAC key in the cache directory (entries written elsewhere are not read)")
        raw = path.read_bytes()
        mac_path = path.with_name(path.name + ".mac")
        try:
            mac = mac_path.read_text().strip()
        except (OSError, UnicodeDecodeError):
            raise ValueError("no MAC file: an entry this toolbox did not write") from None
        expected = hmac.new(key, raw, hashlib.sha256).hexdigest().encode()
        if not hmac.compare_digest(mac.encode("utf-8", "surrogateescape"), expected):  # bytes: any text compares
            raise ValueError("its MAC does not match: an entry this toolbox did not write, or one edited since")
        return raw

    def _store(self, tmp: Path, path: Path) -> None:
        """Move the written ``tmp`` to ``path`` with its MAC (the MAC last: a reader meanwhile refuses)."""
        key = self._mac_key(create=True)
        if key is None:
            raise OSError("the cache's MAC key is not this user's private file")
        mac = hmac.new(key, tmp.read_bytes(), hashlib.sha256).hexdigest()
        mac_tmp = path.with_name(path.name + f".mac.tmp{os.getpid()}")
        mac_tmp.write_text(mac)
        os.replace(tmp, path)
        os.replace(mac_tmp, path.with_name(path.name + ".mac"))

    def _writable(self) -> bool:
        if self._unwritable or not self._trusted():
            return False
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            probe = self.directory / f".write-test-{os.getpid()}"
            probe.write_bytes(b"")
            probe.unlink()
            return True
        except OSError as exc:
            self._unwritable = True
            if self.log is not None:
                self.log(f"cache directory {self.directory} is not writable ({exc.strerror or exc}); "
                         f"running without a cache (set {CACHE_DIR_ENV} or pass --no-cache)")
            return False

    # ------------------------------------------------------------------ analyses
    def analysis(self, system, T: int, compute: Callable[[], Any], what: str | None = None):
        """The analysis of ``system`` at horizon ``T``: loaded from the cache, else ``compute()`` and stored.

        Parameters
        ----------
        system : PWASystem
        T : int
        compute : callable
            ``compute()`` returns the :class:`~hybobs_opt.regions.ObservabilityAnalysis` (on a
            miss, or when the entry is refused).
        what : str, optional
            What the events call the entry (default: the system's name and ``T``).

        Returns
        -------
        ObservabilityAnalysis
            The stored analysis, or the one ``compute()`` returned (then stored).
        """
        from .regions.io import load_analysis, save_analysis
        from .systems.fingerprint import system_fingerprint

        what = what or f"observability analysis of {system.name!r} (T = {T})"
        key = self.key("analysis", {"fingerprint": system_fingerprint(system), "T": int(T)})
        path = self.path("analysis", key, ".json")
        t0 = time.perf_counter()
        reason = None
        if path.exists() and self._trusted():
            import tempfile

            try:
                raw = self._verified_bytes(path)
                # parsed from a private copy of the verified bytes: the entry may change meanwhile
                with tempfile.TemporaryDirectory(prefix="hybobs_entry_") as private:
                    copy = Path(private) / path.name
                    copy.write_bytes(raw)
                    analysis = load_analysis(copy, system=system)
                if analysis.T != T:
                    raise ModelError(str(path), f"an analysis with T = {T}", f"T = {analysis.T}")
                self._event("analysis", what, "hit", path, time.perf_counter() - t0)
                return analysis
            except (ModelError, OSError, ValueError) as exc:
                reason = str(exc)
        analysis = compute()
        if self._writable():
            tmp = path.with_name(path.name + f".tmp{os.getpid()}")
            try:
                save_analysis(analysis, tmp)
                self._store(tmp, path)  # atomic: a reader sees the old entry or the whole new one
            except OSError as exc:
                tmp.unlink(missing_ok=True)
                self._event("analysis", what, "not stored", path, time.perf_counter() - t0, str(exc))
                return analysis
            self._event("analysis", what, "refused" if reason else "stored", path, time.perf_counter() - t0, reason)
        else:
            self._event("analysis", what, "not stored", path, time.perf_counter() - t0, reason)
        return analysis

    # ------------------------------------------------------------------ arrays
    def arrays(self, kind: str, parts: Mapping[str, Any], compute: Callable[[], Mapping[str, np.ndarray]],
               what: str) -> dict[str, np.ndarray]:
        """Named arrays for ``kind``/``parts``: loaded from the cache, else ``compute()`` and stored.

        Parameters
        ----------
        kind : str
            The kind of entry (the file name's prefix, ``"lookup-pieces"``).
        parts : mapping
            What the entry depends on besides the code (JSON-serialisable; part of the key).
        compute : callable
            ``compute()`` returns a mapping of names (not starting with ``__``) to numeric or
            string arrays (no objects: entries are read with ``allow_pickle=False``).
        what : str
            What the events call the entry.

        Returns
        -------
        dict of str to ndarray
            The stored arrays, or the ones ``compute()`` returned (then stored).
        """
        key = self.key(kind, parts)
        path = self.path(kind, key, ".npz")
        t0 = time.perf_counter()
        reason = None
        if path.exists() and self._trusted():
            try:
                out = self._read_arrays(self._verified_bytes(path), key)
                self._event(kind, what, "hit", path, time.perf_counter() - t0)
                return out
            except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
                reason = f"{type(exc).__name__}: {exc}"
        arrays = {name: np.asarray(a) for name, a in compute().items()}
        if any(name.startswith("__") for name in arrays) or any(a.dtype == object for a in arrays.values()):
            raise ModelError(f"cache entry {kind}", "arrays of numbers or strings under names without a leading '__'",
                             sorted(arrays))
        if not self._writable():
            self._event(kind, what, "not stored", path, time.perf_counter() - t0, reason)
            return arrays
        tmp = path.with_name(path.name + f".tmp{os.getpid()}.npz")
        try:
            np.savez_compressed(tmp, __key__=np.array(key), __digest__=np.array(array_digest(arrays)), **arrays)
            self._store(tmp, path)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            self._event(kind, what, "not stored", path, time.perf_counter() - t0, str(exc))
            return arrays
        self._event(kind, what, "refused" if reason else "stored", path, time.perf_counter() - t0, reason)
        return arrays

    @staticmethod
    def _read_arrays(raw: bytes, key: str) -> dict[str, np.ndarray]:
        with np.load(io.BytesIO(raw), allow_pickle=False) as data:
            out = {name: data[name] for name in data.files}
        if str(out.pop("__key__", "")) != key:
            raise ValueError("the entry was written for another key")
        digest = str(out.pop("__digest__", ""))
        if digest != array_digest(out):
            raise ValueError("the arrays do not match their SHA-256 (a corrupted entry)")
        return out

    # ------------------------------------------------------------------ housekeeping
    def entries(self) -> list[dict[str, Any]]:
        """The entries on disk: ``name``, ``kind``, ``bytes``, ``modified`` (POSIX time), sorted by name.

        Returns
        -------
        list of dict
            One record per entry: ``name``, ``kind``, ``bytes``, ``modified``.
        """
        if not self.directory.is_dir():
            return []
        out = []
        for path in sorted(self.directory.iterdir()):
            if _ENTRY.fullmatch(path.name) and path.is_file() and not path.is_symlink():
                st = path.stat()
                out.append({"name": path.name, "kind": path.name.rsplit("-", 1)[0], "bytes": st.st_size,
                            "modified": st.st_mtime})
        return out

    def clear(self) -> tuple[int, int]:
        """Delete the toolbox's entries, their MACs and stale temporary files (files of its naming
        pattern only: nothing else in the directory is touched); returns ``(files, bytes)`` removed.

        Returns
        -------
        (int, int)
            The number of files and of bytes removed.
        """
        if not self.directory.is_dir():
            return 0, 0
        files = size = 0
        for path in self.directory.iterdir():
            if _OWN_FILE.fullmatch(path.name) and (path.is_file() or path.is_symlink()):
                size += path.lstat().st_size
                path.unlink()
                files += 1
        return files, size


_ACTIVE: ContextVar[ResultCache | None] = ContextVar("hybobs_opt_active_cache", default=None)


@contextmanager
def use_cache(cache: ResultCache | None) -> Iterator[ResultCache | None]:
    """Make ``cache`` the active cache inside the ``with`` block.

    Parameters
    ----------
    cache : ResultCache or None
        The cache that :func:`cached_analysis`, the lookup observer's tables and the exact window
        labels read and write inside the block; ``None`` switches caching off there.

    Yields
    ------
    ResultCache or None
        ``cache``, active until the block ends (the previous active cache is restored then).

    See Also
    --------
    ResultCache : the cache.
    cached_analysis : reads and writes the active cache.

    Examples
    --------
    >>> import tempfile
    >>> from hybobs_opt import ResultCache, cached_analysis, get_example, use_cache
    >>> plant = get_example("powertrain3").build()
    >>> with use_cache(ResultCache(tempfile.mkdtemp(), log=print)) as cache:
    ...     analysis = cached_analysis(plant, 3)
    observability analysis of ...: computed and stored in the cache (...)
    >>> with use_cache(None):                         # caching off inside the block
    ...     analysis = cached_analysis(plant, 3)
    """
    if cache is not None and not isinstance(cache, ResultCache):
        raise ModelError("cache", "a ResultCache or None", type(cache).__name__)
    token = _ACTIVE.set(cache)
    try:
        yield cache
    finally:
        _ACTIVE.reset(token)


def active_cache() -> ResultCache | None:
    """The cache made active by :func:`use_cache`, or ``None`` (compute everything afresh)."""
    return _ACTIVE.get()


def analysis_key_parts(analysis) -> dict[str, Any]:
    """Key parts of a result derived from ``analysis``: the system's fingerprint, ``T`` and a
    digest of the regions' mode sequences, the index set and the pair sets."""
    from .systems.fingerprint import sha256_of, system_fingerprint

    return {"fingerprint": system_fingerprint(analysis.system), "T": int(analysis.T),
            "analysis": sha256_of({"sequences": [list(r.sequence) for r in analysis.regions],
                                   "full_rank": [bool(v) for v in analysis.full_rank],
                                   "pairs": [[int(p.i), int(p.j)] for p in analysis.pairs]})}


def cached_analysis(system, T: int, *, executor=None, progress=None):
    """:func:`~hybobs_opt.regions.analyse_observability` of ``system`` at ``T``, through the active cache.

    Without an active cache this is ``analyse_observability(system, T, executor=executor,
    progress=progress)``; with one, a stored analysis of the same system (same fingerprint),
    horizon and code is loaded and checked instead.

    Parameters
    ----------
    system : PWASystem
    T : int
        Horizon (``T p >= n``, eq. 8 of paper 002).
    executor : Executor, optional
        Where the LPs run when the analysis is computed.
    progress : callable or PhaseProgress, optional
        As for :func:`~hybobs_opt.regions.analyse_observability` (not called on a hit).

    Returns
    -------
    ObservabilityAnalysis

    See Also
    --------
    hybobs_opt.regions.analyse_observability : the computation itself.
    use_cache, ResultCache : the active cache.

    Examples
    --------
    Without an active cache it computes the analysis; inside ``use_cache`` the second call loads
    what the first stored:

    >>> import numpy as np, tempfile
    >>> from hybobs_opt import ResultCache, cached_analysis, get_example, use_cache
    >>> plant = get_example("powertrain3").build()
    >>> cached_analysis(plant, 3).is_observable(np.array([0.06, 39.0, 3.25]))
    True
    >>> with use_cache(ResultCache(tempfile.mkdtemp(), log=print)):
    ...     analysis = cached_analysis(plant, 3)
    ...     analysis = cached_analysis(plant, 3)
    observability analysis of ...: computed and stored in the cache (...)
    observability analysis of ...: loaded from the cache (...)
    """
    from .regions import analyse_observability

    def compute():
        return analyse_observability(system, T, executor=executor, progress=progress)

    from .regions.enumeration import check_horizon
    from .systems.pwa import PWASystem

    cache = active_cache()
    if cache is None or not isinstance(system, PWASystem):
        return compute()  # (analyse_observability refuses what is not a PWASystem)
    check_horizon(system, T)  # before the key is computed from it
    return cache.analysis(system, T, compute)
