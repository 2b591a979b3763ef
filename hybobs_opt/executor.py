"""One executor abstraction for long work: serial, local processes, or a Dask cluster.

``map(fn, items)`` always returns results in the order of ``items``, so every executor gives
the same answer (DESIGN.md: "the same inputs give the same regions, in the same order").
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from typing import Any

from .errors import ModelError

Progress = Callable[[int, int], None] | None

#: ``ProcessExecutor.map_shared`` writes shared data at least this large (pickled) once into a
#: private file that every worker reads once, instead of pickling them into every task: the pair
#: tests of model (17) at T = 9 share 35 MB over 16 tasks (0.09 s of pickling and unpickling a task).
SHARED_FILE_MIN_BYTES = 1 << 20

#: Worker side of :meth:`ProcessExecutor.map_shared`: ``(path, unpickled data)`` of the last file read.
_SHARED_FILE: tuple = (None, None)


def _call_with_file(fn, item, path: str):
    """``fn(item, shared)`` in a worker, ``shared`` unpickled from the parent's file ``path`` once per worker.

    The file lies in a directory the calling process created for this map alone (owner-only
    permissions, random name; the same trust as the pipe the pool pickles its tasks through) and
    removes when the map ends.
    """
    global _SHARED_FILE
    if _SHARED_FILE[0] != path:
        import pickle

        _SHARED_FILE = (None, None)  # drop the previous data before loading the next
        with open(path, "rb") as fh:
            _SHARED_FILE = (path, pickle.load(fh))
    return fn(item, _SHARED_FILE[1])


def _gather(futures, progress: Progress) -> list[Any]:
    """Results of ``futures`` in submission order, reporting progress as each one arrives in turn."""
    out = []
    for k, fut in enumerate(futures):
        out.append(fut.result())
        if progress:
            progress(k + 1, len(futures))
    return out


class SerialExecutor:
    """Run everything in this process.

    See Also
    --------
    ProcessExecutor, DaskExecutor : the same interface on local processes or a Dask cluster.
    make_executor : one of the three from command-line style options.

    Examples
    --------
    >>> from hybobs_opt import SerialExecutor
    >>> executor = SerialExecutor()
    >>> executor.map(abs, [-1, 2, -3])
    [1, 2, 3]
    >>> executor.map_shared(pow, [1, 2, 3], 2)      # pow(item, 2)
    [1, 4, 9]
    >>> executor.close()
    """

    name = "serial"
    n_workers = 1

    def map_shared(self, fn, items, shared, progress: Progress = None) -> list[Any]:
        """``[fn(item, shared) for item in items]``: :meth:`map` with one argument common to all calls.

        Returns
        -------
        list
            The results, in the order of ``items``.
        """
        return self.map(lambda item: fn(item, shared), items, progress)

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any], progress: Progress = None) -> list[Any]:
        """Apply ``fn`` to every item in turn.

        Parameters
        ----------
        fn : callable
            ``fn(item)``.
        items : iterable
            The work items.
        progress : callable, optional
            ``progress(done, total)`` as each result arrives, in order.

        Returns
        -------
        list
            ``[fn(item) for item in items]``, in the order of ``items``.
        """
        items = list(items)
        out = []
        for k, item in enumerate(items):
            out.append(fn(item))
            if progress:
                progress(k + 1, len(items))
        return out

    def close(self) -> None:
        pass


def _end_with_parent(parent: int) -> None:
    """Worker initializer: the worker ends when its parent does (killed with ``SIGKILL``, it cannot
    shut its pool down).  On Linux the kernel sends ``SIGTERM`` on the parent's death
    (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread watches the parent's pid."""
    import signal
    import sys
    import threading

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(1, int(signal.SIGTERM), 0, 0, 0) == 0:  # 1 = PR_SET_PDEATHSIG
                if os.getppid() != parent:  # the parent died before the call: nobody will signal
                    os._exit(1)
                return
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        import time

        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="hybobs-parent-watch", daemon=True).start()


class ProcessExecutor:
    """Local worker processes (``concurrent.futures``), all cores by default.

    Parameters
    ----------
    n_workers : int, optional
        Number of processes (default: ``os.cpu_count()``).

    See Also
    --------
    SerialExecutor : the same interface in this process.
    make_executor : an executor from command-line style options.

    Examples
    --------
    The analyses that accept an ``executor`` (:func:`~hybobs_opt.regions.analyse_observability`)
    spread their work over its processes; ``map`` keeps the order of the items:

    >>> from hybobs_opt import ProcessExecutor
    >>> executor = ProcessExecutor(n_workers=2)
    >>> executor.map(abs, [-1, 2, -3])
    [1, 2, 3]
    >>> executor.close()
    """

    name = "processes"

    def __init__(self, n_workers: int | None = None):
        n = n_workers or os.cpu_count() or 1
        if n < 1:
            raise ModelError("n_workers", "a positive number of processes", repr(n_workers))
        self.n_workers = int(n)
        self._pool = None

    def _get_pool(self):
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            # fork is cheap and inherits the imported package; fall back to spawn where absent.
            ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context("spawn")
            self._pool = ProcessPoolExecutor(max_workers=self.n_workers, mp_context=ctx, initializer=_end_with_parent,
                                             initargs=(os.getpid(),))
        return self._pool

    def map(self, fn, items, progress: Progress = None) -> list[Any]:
        """Apply ``fn`` to the items in the worker processes (serially for one item or one worker).

        Parameters
        ----------
        fn : callable
            ``fn(item)``, picklable (module-level) for the worker processes.
        items : iterable
            The work items.
        progress : callable, optional
            ``progress(done, total)`` as each result arrives, in order.

        Returns
        -------
        list
            ``[fn(item) for item in items]``, in the order of ``items``.
        """
        items = list(items)
        if len(items) <= 1 or self.n_workers == 1:
            return SerialExecutor().map(fn, items, progress)
        pool = self._get_pool()
        return _gather([pool.submit(fn, item) for item in items], progress)

    def map_shared(self, fn, items, shared, progress: Progress = None) -> list[Any]:
        """``[fn(item, shared) for item in items]`` in the worker processes.

        ``shared`` is pickled once; from :data:`SHARED_FILE_MIN_BYTES` on it travels in one
        private temporary file that each worker unpickles once (the tasks carry only its path),
        below that with each item.

        Returns
        -------
        list
            The results, in the order of ``items``.
        """
        import pickle

        items = list(items)
        if len(items) <= 1 or self.n_workers == 1:
            return SerialExecutor().map_shared(fn, items, shared, progress)
        pool = self._get_pool()
        payload = pickle.dumps(shared, protocol=pickle.HIGHEST_PROTOCOL)
        if len(payload) < SHARED_FILE_MIN_BYTES:
            return _gather([pool.submit(fn, item, shared) for item in items], progress)
        import shutil
        import tempfile

        # RAM-backed where the system has it; the directory is 0700 and unique to this call
        where = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
        folder = tempfile.mkdtemp(prefix="hybobs-shared-", dir=where)
        try:
            path = os.path.join(folder, "shared.pickle")
            with open(path, "xb") as fh:
                fh.write(payload)
            del payload
            return _gather([pool.submit(_call_with_file, fn, item, path) for item in items], progress)
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


class DaskExecutor:
    """A Dask distributed cluster: an existing scheduler (``tcp://HOST:PORT``) or a ``LocalCluster``.

    Needs the ``distributed`` extra (``pip install hybobs_opt[distributed]``).

    Parameters
    ----------
    scheduler : str, optional
        Address of an existing scheduler (``tcp://HOST:PORT``); give it or ``local_workers``.
    local_workers : int, optional
        Size of a ``LocalCluster`` started here (one thread per worker process).

    Raises
    ------
    ModelError
        If ``distributed`` is not installed, both or neither are given, or ``local_workers < 1``.

    See Also
    --------
    ProcessExecutor : local processes without Dask.
    make_executor : ``dask_local`` / ``scheduler`` give this executor.

    Examples
    --------
    A one-worker local cluster (a few seconds to start); ``scheduler="tcp://HOST:PORT"`` joins a
    running one instead:

    >>> from hybobs_opt import DaskExecutor
    >>> executor = DaskExecutor(local_workers=1)
    >>> executor.map(abs, [-1, 2, -3])
    [1, 2, 3]
    >>> executor.close()
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, local_workers: int | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the extra
            raise ModelError("executor", "the 'distributed' extra installed (pip install 'hybobs_opt[distributed]')", str(exc)) from None
        if (scheduler is None) == (local_workers is None):
            raise ModelError("executor", "exactly one of a scheduler address or a LocalCluster size", f"scheduler={scheduler!r}, local_workers={local_workers!r}")
        self._cluster = None
        if scheduler is not None:
            self._client = Client(scheduler)
        else:
            if local_workers < 1:
                raise ModelError("local_workers", "a positive number of workers", repr(local_workers))
            self._cluster = LocalCluster(n_workers=int(local_workers), threads_per_worker=1, processes=True,
                                         host="127.0.0.1", dashboard_address=None)
            self._client = Client(self._cluster)
        self.n_workers = max(1, len(self._client.scheduler_info().get("workers", {})) or (local_workers or 1))

    def map(self, fn, items, progress: Progress = None) -> list[Any]:
        """Apply ``fn`` to the items on the cluster.

        Parameters
        ----------
        fn : callable
            ``fn(item)``, serialisable for the workers.
        items : iterable
            The work items.
        progress : callable, optional
            ``progress(done, total)`` as each result arrives, in order.

        Returns
        -------
        list
            ``[fn(item) for item in items]``, in the order of ``items``.
        """
        items = list(items)
        return _gather(self._client.map(fn, items, pure=False), progress)

    def map_shared(self, fn, items, shared, progress: Progress = None) -> list[Any]:
        """``[fn(item, shared) for item in items]`` on the cluster, ``shared`` sent to every worker once.

        Embedded in every task instead, large shared data make a large task graph (model 17 at
        T = 9: 34 MB for 4 tasks, and Dask warns); scattered, it travels once per worker.

        Returns
        -------
        list
            The results, in the order of ``items``.
        """
        items = list(items)
        [future] = self._client.scatter([shared], broadcast=True, hash=False)
        return _gather(self._client.map(fn, items, shared=future, pure=False), progress)

    def close(self) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(kind: str = "processes", n_workers: int | None = None, scheduler: str | None = None,
                  dask_local: int | None = None):
    """Build an executor from CLI-style options (``--scheduler`` / ``--dask-local`` win over ``kind``).

    Parameters
    ----------
    kind : {"processes", "serial"}, default "processes"
        The local executor.
    n_workers : int, optional
        Processes of a :class:`ProcessExecutor` (default: all cores).
    scheduler : str, optional
        Address of a Dask scheduler: gives a :class:`DaskExecutor`.
    dask_local : int, optional
        Workers of a Dask ``LocalCluster``: gives a :class:`DaskExecutor`.

    Returns
    -------
    SerialExecutor, ProcessExecutor or DaskExecutor
        The executor the options name; the caller closes it.

    Raises
    ------
    ModelError
        On an unknown ``kind``.

    See Also
    --------
    SerialExecutor, ProcessExecutor, DaskExecutor : what it builds.

    Examples
    --------
    >>> from hybobs_opt import make_executor
    >>> executor = make_executor("serial")
    >>> type(executor).__name__, executor.map(abs, [-2, 3])
    ('SerialExecutor', [2, 3])
    >>> executor.close()
    >>> make_executor("threads")
    Traceback (most recent call last):
    ...
    hybobs_opt.errors.ModelError: executor: expected ...
    """
    if scheduler is not None or dask_local is not None:
        return DaskExecutor(scheduler, dask_local)
    if kind == "serial":
        return SerialExecutor()
    if kind == "processes":
        return ProcessExecutor(n_workers)
    raise ModelError("executor", "'serial', 'processes' or a Dask option", repr(kind))


def resolve_executor(executor=None):
    """The executor an analysis runs on: ``None`` is serial, a string is a kind of
    :func:`make_executor` (``"serial"`` or ``"processes"``), an executor passes as it is.

    Raises
    ------
    ModelError
        ``executor`` is neither (it must have ``map``, ``n_workers`` and ``name``, like
        :class:`SerialExecutor`, :class:`ProcessExecutor` and :class:`DaskExecutor`).
    """
    if executor is None:
        return SerialExecutor()
    if isinstance(executor, str):
        return make_executor(executor)
    if not all(hasattr(executor, a) for a in ("map", "n_workers", "name")):
        raise ModelError("executor", "None, 'serial', 'processes' or an executor of hybobs_opt.executor",
                         type(executor).__name__)
    return executor
