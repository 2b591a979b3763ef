"""Where numba keeps the package's compiled kernels, and warming them up.

The kernels (``geometry/_lp_kernels.py``, ``geometry/_vertex_kernels.py``,
``observers/_lookup_kernels.py``) are ``@njit(cache=True)``: compiled once, then loaded from
disk.  numba writes that cache next to the source by default, which a wheel in a read-only
``site-packages`` cannot do; :func:`configure` (run by each kernel module as it turns its kernels
into numba dispatchers) points it at the user's cache instead:

    ``$NUMBA_CACHE_DIR`` if the user set it (even empty: then numba's own choice), else
    ``$HYBOBS_CACHE_DIR/numba``, else ``$XDG_CACHE_HOME/hybobs_opt/numba``, else
    ``~/.cache/hybobs_opt/numba`` -- the directory of :class:`hybobs_opt.cache.ResultCache`
    plus ``numba``.

It sets numba's ``config.CACHE_DIR`` (what ``NUMBA_CACHE_DIR`` sets when numba is imported) and
leaves the process environment alone: importing the package changes no environment variable.
Every process (a worker, the background compilation) computes the same directory from the same
variables; a child this package starts gets it explicitly.
A directory that cannot be created or written costs nothing: numba then falls back to its own
locations (next to the source if writable, else its per-user directory) and runs the same code.
numba keys every entry by a hash of the kernel's source file, so an edited checkout never loads a
stale kernel.

Measured in fresh processes (``benchmarks/bench_startup.py``, ``first_calls``): with an empty
cache the kernels compile on first use (tens of seconds on this machine); with the cache present
the first kernel call of a process still pays numba's one-time set-up of its compiler tables
(0.4-0.6 s here) and a few milliseconds per kernel loaded.  :func:`prepare_target` does that
set-up when a kernel module is imported, so the first call costs what the next ones do; a
background thread was measured too and gains nothing (the set-up holds the GIL).

Tiers.  Importing numba and loading its tables cost about 0.6 s of CPU: more than a small analysis
(powertrain3, T = 3) takes with the kernels as plain Python.  So the geometry kernel modules start
*tiered* when the cache is known to hold their kernels (:func:`finalize_kernels` with
``tiered=True``, the record :data:`WARM_RECORD` says so): their kernels run as Python, each call
adds the module's weight to one per-process count, and when the count reaches
:data:`~hybobs_opt.defaults.KERNEL_TIER_UP_WORK` every tiered module loads its compiled kernels
(:func:`tier_up`) and the Python ones are not called again.  The count depends on the work only,
so the switch comes at the same call on every machine, and the answers do not depend on it: the
Python and compiled kernels give the same bits (``tests/unit/test_kernel_modes.py``,
``scripts/check_reproducible.py``).  Runtime observers call :func:`tier_up` when they are built, so
no step of theirs pays for the switch.
:func:`hybobs_opt.warm_up` (:mod:`hybobs_opt._warm_up`) compiles or loads every kernel once: after an
install, ``python -m hybobs_opt._warm_up``, or in a service's start-up.
"""

from __future__ import annotations

import os
import sys

from ._environment import KERNELS_ENV, background_warm_up_allowed, cache_root, kernels_mode

#: numba's environment variable for its cache directory.
NUMBA_CACHE_ENV = "NUMBA_CACHE_DIR"

__all__ = ["NUMBA_CACHE_ENV", "WARM_RECORD", "cache_directory", "configure", "finalize_kernels", "kernel", "kernels_compiled",
           "numba_cache_dir", "prepare_target", "record_warm_kernels", "tier_up"]

# HYBOBS_KERNELS -- ``auto`` (default): a kernel module whose compiled kernels are in the cache uses
# them; one whose cache is empty or stale runs its kernels as plain Python in this process and, at
# the first kernel call, starts one background process that compiles them into the cache
# (:func:`finalize_kernels`).  ``compiled``: always numba.  ``python``: never numba.
# HYBOBS_BACKGROUND_WARM_UP=0 keeps ``auto`` from starting the background compilation.
#: A background compilation younger than this (seconds) is not started again (its lock file).
WARM_UP_LOCK_SECONDS = 900.0


def numba_cache_dir() -> str:
    """The package's numba cache: ``numba`` inside the cache directory (:func:`hybobs_opt._environment.cache_root`)."""
    return os.path.join(cache_root(), "numba")


def cache_directory() -> str:
    """The kernel cache directory in force: ``$NUMBA_CACHE_DIR`` when the user set it (even empty:
    numba's own choice), else :func:`numba_cache_dir`."""
    if NUMBA_CACHE_ENV in os.environ:
        return os.environ[NUMBA_CACHE_ENV]
    return numba_cache_dir()


def configure() -> str:
    """Point numba's cache at :func:`cache_directory`; returns that directory.

    Sets numba's ``config.CACHE_DIR`` when numba is imported (a kernel module calls this before
    creating its dispatchers, whose cache locator reads it) and nothing else: no environment
    variable, no directory created (numba creates it on first use, and skips it silently when it
    cannot write there).  A ``NUMBA_CACHE_DIR`` the user set is numba's own setting already.
    """
    path = cache_directory()
    config = sys.modules.get("numba.core.config")
    if config is not None and NUMBA_CACHE_ENV not in os.environ:
        config.CACHE_DIR = path
    return path


_prepared = False


def prepare_target() -> None:
    """numba's one-time set-up of its CPU target (typing and lowering tables), once per process.

    Loading a cached kernel does it anyway on the first call; the kernel modules call this at
    import so that the first call of an analysis or an observer costs what the second does.
    """
    global _prepared
    if _prepared:
        return
    from numba.core.registry import cpu_target

    cpu_target.typing_context.refresh()
    cpu_target.target_context.refresh()
    _prepared = True


# ---------------------------------------------------------------------- kernels: compiled or not
_COMPILED: dict[str, bool] = {}  # module name -> its kernels are numba dispatchers
_background_started = False


def kernel(*signatures, **options):
    """Mark a function as a numba kernel (``numba.njit(*signatures, **options)``); :func:`finalize_kernels` decides.

    The function is returned unchanged: until the module calls :func:`finalize_kernels`, nothing is
    compiled or loaded (an eager signature would otherwise compile at import: 15 s of the 16 s
    cold import of the lookup observer).
    """
    def mark(fn):
        fn._hybobs_kernel = (signatures, options)
        return fn
    return mark


def _cache_has(fn) -> bool:
    """Does numba's cache hold a compiled version of ``fn`` for its current source (index fresh, non-empty)?"""
    try:
        from numba.core.caching import FunctionCache

        configure()
        return bool(FunctionCache(fn)._cache_file._load_index())
    except Exception:  # numba's cache API moved: take the cache as warm (the behaviour before)
        return True


def finalize_kernels(namespace: dict, *, tiered: bool = False, python: dict | None = None, weight: int = 1) -> bool:
    """Turn the module's :func:`kernel` functions into numba dispatchers, or keep them Python.

    With ``HYBOBS_KERNELS=auto`` (the default) the module's kernels are compiled -- that is,
    loaded from the cache in milliseconds -- when the cache holds any of them for the current
    source; otherwise (a fresh install, an edited source) they stay plain Python functions in
    this process, which runs at once instead of compiling for tens of seconds, and one background
    process (``python -m hybobs_opt._warm_up``, lock file in the cache directory) compiles every
    kernel into the cache for the next processes.  The answers are the same either way (the same
    code; ``tests/unit/test_kernel_modes.py`` checks analyses and observers against each other).

    With ``tiered=True`` and ``auto``, a module whose kernels :data:`WARM_RECORD` vouches for (and
    no :func:`tier_up` yet in this process) starts tiered (module docstring): each kernel name holds
    a counting function that calls ``python[name]`` (default: the kernel itself) until
    :func:`tier_up`, and the compiled kernel after it.  ``weight`` is what one call adds to the
    count (a loop kernel costs more as Python than a NumPy one).

    Returns whether the kernels are compiled or tiered (the namespace's kernel names will reach
    compiled code), False when they stay Python.
    """
    marked = {name: fn for name, fn in namespace.items() if callable(fn) and hasattr(fn, "_hybobs_kernel")}
    mode = kernels_mode()
    untrusted = _untrusted_cache()
    if tiered and mode == "auto" and not untrusted and not _TIER.done and _record_vouches(namespace):
        return _finalize_tiered(namespace, marked, python or {}, weight)
    if untrusted:
        # numba's index files are pickles: a directory another user can write is never read
        # (compiled on request without the cache, else Python kernels and no background compilation)
        compiled = mode == "compiled"
    else:
        # an unwritable cache would keep every process on Python kernels: compile then, as numba
        # does (it falls back on its own locations)
        compiled = mode == "compiled" or (mode == "auto" and (any(_cache_has(fn) for fn in marked.values())
                                                              or not _cache_writable()))
    if compiled:
        ok = _compile(namespace, marked, mode, untrusted)
        if ok and tiered and mode == "auto" and not untrusted:
            record_warm_kernels([namespace])  # the cache holds them: the next processes may start tiered
        return ok
    return _finalize_python(namespace, marked, mode, untrusted)


def _compile(namespace: dict, marked: dict, mode: str, untrusted) -> bool:
    """The module's kernels as numba dispatchers (loaded from the cache, or compiled on use)."""
    from numba import njit

    configure()  # numba is imported now: its cache locator reads config.CACHE_DIR at njit
    prepare_target()
    try:
        for name, fn in marked.items():
            signatures, options = fn._hybobs_kernel
            if untrusted:
                options = {**options, "cache": False}
            # into the namespace at once: the next kernels call this one by its global name
            namespace[name] = njit(*signatures, **options)(fn)
            if not signatures and options.get("cache"):
                _tolerate_damaged_entries(namespace[name])
    except Exception as exc:  # a damaged cache entry (truncated pickle, ...) read by an eager signature
        import warnings

        namespace.update(marked)  # the Python functions again, then one of the two ways below
        dropped = _drop_cache_entries(marked.values())
        warnings.warn(f"hybobs_opt: a kernel of {namespace.get('__name__', '?')} could not be loaded from the "
                      f"cache ({type(exc).__name__}: {exc}); {dropped} damaged cache files removed, "
                      + ("compiling again" if mode == "compiled" else "its kernels run as Python this time"),
                      RuntimeWarning, stacklevel=2)
        if mode != "compiled":
            return _finalize_python(namespace, marked, mode, untrusted=False)
        for name, fn in marked.items():
            namespace[name] = njit(*fn._hybobs_kernel[0], **fn._hybobs_kernel[1])(fn)
    _COMPILED[namespace.get("__name__", "?")] = True
    return True


# ---------------------------------------------------------------------------------- kernel tiers
class _TierState:
    """The per-process count of tiered kernel work and the tiered modules (module docstring)."""

    def __init__(self):
        import threading

        self.work = 0
        self.done = False
        self.modules: list[tuple[dict, dict, dict, dict]] = []  # (namespace, marked, python, trampolines)
        self.lock = threading.RLock()


_TIER = _TierState()


def _finalize_tiered(namespace: dict, marked: dict, python: dict, weight: int) -> bool:
    from .defaults import KERNEL_TIER_UP_WORK

    tier = _TIER
    trampolines = {}
    for name, fn in marked.items():
        target = [python.get(name, fn)]

        def tiered(*args, _target=target):
            if not tier.done:
                tier.work += weight
                if tier.work >= KERNEL_TIER_UP_WORK:
                    tier_up()
            return _target[0](*args)

        tiered.__name__, tiered.__qualname__, tiered.__doc__ = fn.__name__, fn.__qualname__, fn.__doc__
        tiered.__module__ = fn.__module__
        tiered.__wrapped__ = fn
        tiered._hybobs_target = target
        trampolines[name] = namespace[name] = tiered
    tier.modules.append((namespace, marked, python, trampolines))
    _COMPILED[namespace.get("__name__", "?")] = False
    return True


def tier_up(background: bool = True) -> dict[str, bool]:
    """Load the compiled kernels of every tiered module now (see the module docstring).

    A runtime observer calls it when it is built, so that no step pays for it; an analysis reaches
    it through the kernel work count.  A module whose kernels turn out not to be in the cache (a
    record older than the cache's contents) keeps its Python kernels in this process and, in
    ``auto`` with ``background``, starts the background compilation (the warm-up, which compiles
    itself, passes False).  The kernel functions other package modules imported
    by name are replaced there by the compiled ones (a lookup of the module's globals, once).
    Returns :func:`kernels_compiled`.
    """
    tier = _TIER
    with tier.lock:
        if tier.done:
            return kernels_compiled()
        tier.done = True
        if not tier.modules:
            return kernels_compiled()
        swap: dict[int, tuple] = {}
        mode = kernels_mode()
        for namespace, marked, python, trampolines in tier.modules:
            for name, fn in marked.items():  # the Python kernels in the namespace while deciding
                namespace[name] = fn
            if any(_cache_has(fn) for fn in marked.values()) and _compile(namespace, marked, mode, None):
                targets = {name: namespace[name] for name in marked}
            else:
                _finalize_python(namespace, marked, "python", untrusted=False)
                if background and mode == "auto" and background_warm_up_allowed():
                    start_background_warm_up()
                targets = {name: python.get(name, namespace[name]) for name in marked}
            for name, t in trampolines.items():
                t._hybobs_target[0] = targets[name]
                swap[id(t)] = (t, targets[name])
        tier.modules.clear()
        _swap_imported(swap)
    return kernels_compiled()


def _swap_imported(swap: dict[int, tuple]) -> None:
    """Replace the tiered functions bound in the package's modules (``from ._lp_kernels import f``,
    module aliases) by their targets: one call less per kernel call from then on."""
    for mod in list(sys.modules.values()):
        if not getattr(mod, "__name__", "").startswith("hybobs_opt"):
            continue
        try:
            d = vars(mod)
        except TypeError:
            continue
        for key, value in list(d.items()):
            hit = swap.get(id(value))
            if hit is not None and hit[0] is value:
                d[key] = hit[1]


#: The record, in the kernel cache directory, of the kernel modules whose compiled kernels the cache
#: holds (JSON: path of its source file -> sha256 of that file; several checkouts may share a cache).  Written by the warm-up and by a process
#: that found a module's kernels in the cache; read by :func:`finalize_kernels` to start a module
#: tiered without importing numba (its cache index is numba's pickle).  A wrong record costs time
#: only: :func:`tier_up` checks numba's own cache before it loads a kernel.
WARM_RECORD = "hybobs-kernels.json"
_SOURCE_DIGESTS: dict[str, str | None] = {}


def _source_digest(namespace: dict) -> str | None:
    path = namespace.get("__file__")
    if not path:
        return None
    if path not in _SOURCE_DIGESTS:
        import hashlib

        try:
            with open(path, "rb") as f:
                _SOURCE_DIGESTS[path] = hashlib.sha256(f.read()).hexdigest()
        except OSError:
            _SOURCE_DIGESTS[path] = None
    return _SOURCE_DIGESTS[path]


def _read_record() -> dict:
    import json

    cache = cache_directory()
    if not cache:
        return {}
    try:
        with open(os.path.join(cache, WARM_RECORD), encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return {}
    sources = data.get("sources") if isinstance(data, dict) else None
    return sources if isinstance(sources, dict) else {}


def _record_vouches(namespace: dict) -> bool:
    digest = _source_digest(namespace)
    return digest is not None and _read_record().get(namespace.get("__file__")) == digest


def record_warm_kernels(namespaces=None) -> None:
    """Add the given kernel modules (default: every module compiled in this process) to :data:`WARM_RECORD`.

    Written atomically (a temporary file renamed); a cache directory that cannot be written is left alone.
    """
    import json

    cache = cache_directory()
    if not cache or _untrusted_cache():
        return
    if namespaces is None:
        namespaces = [vars(sys.modules[m]) for m, ok in _COMPILED.items() if ok and m in sys.modules]
    sources = _read_record()
    changed = False
    for ns in namespaces:
        digest = _source_digest(ns)
        name = ns.get("__file__")
        if digest is not None and name and sources.get(name) != digest:
            sources[name] = digest
            changed = True
    if not changed:
        return
    try:
        os.makedirs(cache, exist_ok=True)
        tmp = os.path.join(cache, f".{WARM_RECORD}.{os.getpid()}")
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump({"format": 1, "sources": sources}, f, indent=1, sort_keys=True)
        os.replace(tmp, os.path.join(cache, WARM_RECORD))
    except OSError:
        pass


def _tolerate_damaged_entries(dispatcher) -> None:
    """Make a lazily compiled kernel read a damaged cache entry as a miss.

    A kernel without declared signatures loads its compiled code from the cache at its first call
    with each argument types, not at import; a truncated or corrupt data file then raised from deep
    inside numba (``UnpicklingError``) in the middle of an analysis.  The dispatcher's cache is
    replaced by one whose failed load warns (once per process) and answers "not cached": numba
    compiles that overload and its save replaces the damaged file.
    """
    cache_class = _tolerant_cache_class()
    if cache_class is None or not isinstance(getattr(dispatcher, "_cache", None), cache_class.__bases__[0]):
        return  # numba's cache API moved, or the kernel is not cached: keep numba's own
    try:
        dispatcher._cache = cache_class(dispatcher.py_func)
    except Exception:  # numba's cache refused the function: keep its own
        pass


_TOLERANT_CACHE = None
_DAMAGED_WARNED = False


def _tolerant_cache_class():
    """numba's ``FunctionCache`` with :meth:`load_overload` turning a failed load into a miss."""
    global _TOLERANT_CACHE
    if _TOLERANT_CACHE is None:
        try:
            from numba.core.caching import FunctionCache
        except ImportError:
            return None

        class TolerantFunctionCache(FunctionCache):
            def load_overload(self, sig, target_context):
                global _DAMAGED_WARNED
                try:
                    return super().load_overload(sig, target_context)
                except Exception as exc:
                    if not _DAMAGED_WARNED:
                        import warnings

                        _DAMAGED_WARNED = True
                        warnings.warn(f"hybobs_opt: the cached kernel {self._py_func.__qualname__} could not be loaded "
                                      f"({type(exc).__name__}: {exc}); compiling the damaged kernels again (their "
                                      "cache entries are replaced)", RuntimeWarning, stacklevel=2)
                    return None

        _TOLERANT_CACHE = TolerantFunctionCache
    return _TOLERANT_CACHE


def _finalize_python(namespace: dict, marked: dict, mode: str, untrusted: bool) -> bool:
    """The module's kernels as Python (typed wrappers where numba signatures are declared)."""
    for name, fn in marked.items():
        if fn._hybobs_kernel[0]:
            namespace[name] = _typed_python(fn, fn._hybobs_kernel[0])
    if mode == "auto" and background_warm_up_allowed() and not untrusted:
        _start_warm_up_on_first_call(namespace, list(marked))
    _COMPILED[namespace.get("__name__", "?")] = False
    return False


def _start_warm_up_on_first_call(namespace: dict, names: list[str]) -> None:
    """Make the first call of any of the module's Python kernels start the background compilation
    (:func:`start_background_warm_up`) and put the plain kernels back: importing a module starts no
    process, using it does."""
    import functools

    plain = {name: namespace[name] for name in names}

    def first_call_of(fn):
        @functools.wraps(fn)
        def first_call(*args, **kwargs):
            namespace.update(plain)  # later calls through the module go straight to the kernels
            start_background_warm_up()
            return fn(*args, **kwargs)

        return first_call

    for name, fn in plain.items():
        namespace[name] = first_call_of(fn)


def _drop_cache_entries(functions) -> int:
    """Remove the cache's index and data files of ``functions`` (numba rewrites them); returns how many."""
    removed = 0
    try:
        from numba.core.caching import FunctionCache
    except ImportError:
        return 0
    configure()
    for fn in functions:
        try:
            cache_file = FunctionCache(fn)._cache_file
            folder, index = cache_file._cache_path, cache_file._index_name
        except Exception:
            continue
        stem = index[: -len(".nbi")]
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        for entry in names:
            if entry == index or (entry.startswith(stem + ".") and entry.endswith(".nbc")):
                try:
                    os.remove(os.path.join(folder, entry))
                    removed += 1
                except OSError:
                    pass
    return removed


def _typed_python(fn, signatures):
    """``fn`` in Python, refusing (``TypeError``) the arguments its explicit numba signatures refuse.

    Callers rely on the dispatcher's ``TypeError`` for arguments of another dtype, dimension or
    memory layout, or read-only arrays (the lookup observer then takes its checked path for the
    sample), so the Python kernel must refuse the same ones, not compute on them.
    """
    import functools

    import numpy as np
    from numba.core import sigutils, types

    accepted = [sigutils.normalize_signature(sig)[0] for sig in signatures]

    def fits(value, ty) -> bool:
        if isinstance(ty, types.Array):
            return (isinstance(value, np.ndarray) and value.dtype == np.dtype(str(ty.dtype)) and value.ndim == ty.ndim
                    and (ty.layout != "C" or value.flags.c_contiguous) and (not ty.mutable or value.flags.writeable))
        if isinstance(ty, (types.Integer, types.Float)):
            # numba converts any real scalar (bool, int, float) to an integer or float parameter
            return isinstance(value, (bool, int, float, np.bool_, np.integer, np.floating))
        return True

    @functools.wraps(fn)
    def checked(*args):
        if not any(len(args) == len(sig) and all(fits(a, t) for a, t in zip(args, sig)) for sig in accepted):
            raise TypeError(f"{fn.__name__}: no matching signature for the argument types (as numba's dispatcher)")
        return fn(*args)

    return checked


_untrusted_reported = False


def _untrusted_cache() -> str | None:
    """Why the kernel cache directory in force may not be read (``None``: it may), said once per process."""
    global _untrusted_reported
    from ._trust import untrusted_directory

    cache = cache_directory()
    if not cache:
        return None  # numba's own choice (next to the installed sources, or its per-user directory)
    why = untrusted_directory(cache)
    if why and not _untrusted_reported:
        import warnings

        _untrusted_reported = True
        warnings.warn(f"hybobs_opt: the kernel cache {cache} {why}: it is not read (its index files are pickles); "
                      f"kernels run as Python (set {NUMBA_CACHE_ENV} to a directory of your own)", RuntimeWarning,
                      stacklevel=3)
    return why


def _cache_writable() -> bool:
    """Can the background compilation write to the package's numba cache directory?"""
    cache = cache_directory() or numba_cache_dir()
    try:
        os.makedirs(cache, exist_ok=True)
    except OSError:
        return False
    return os.access(cache, os.W_OK | os.X_OK)


def kernels_compiled() -> dict[str, bool]:
    """Per kernel module imported so far: are its kernels compiled (numba) or plain Python?"""
    return dict(_COMPILED)


def _lock_holder_alive(lock: str) -> bool:
    """Whether the process named in the warm-up lock file still runs (a lock of a process that
    died, killed mid-compilation, is stale whatever its age)."""
    try:
        with open(lock) as f:
            pid = int(f.read().strip())
    except (OSError, ValueError):
        return True  # being written, or unreadable: the age rule decides
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process: alive
        return True
    try:  # a zombie (finished, not yet reaped) compiles nothing
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[-1][:1] != "Z"
    except OSError:
        return True


def start_background_warm_up() -> bool:
    """Start ``python -m hybobs_opt._warm_up`` detached, once per cache (lock file); True if started."""
    global _background_started
    if _background_started:
        return False
    _background_started = True
    import subprocess
    import time

    cache = cache_directory() or numba_cache_dir()
    lock = os.path.join(cache, "hybobs-warm-up.lock")
    try:
        os.makedirs(cache, exist_ok=True)
        if os.path.exists(lock) and time.time() - os.path.getmtime(lock) < WARM_UP_LOCK_SECONDS \
                and _lock_holder_alive(lock):
            return False  # another process is compiling the kernels
        with open(lock, "w") as f:
            f.write(str(os.getpid()))
    except OSError:
        return False  # no writable cache: numba falls back on its own locations, compile there on use
    env = {**os.environ, KERNELS_ENV: "compiled", NUMBA_CACHE_ENV: cache}
    try:
        child = subprocess.Popen([sys.executable, "-m", "hybobs_opt._warm_up", "--lock", lock], env=env, stdin=subprocess.DEVNULL,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        with open(lock, "w") as f:  # the compiling process, which the next processes check is alive
            f.write(str(child.pid))
    except OSError:  # no compilation runs: the lock must not keep the next processes from trying
        try:
            os.remove(lock)
        except OSError:
            pass
        return False
    return True
