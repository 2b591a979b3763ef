"""Worker processes end with their parent: a parallel analysis whose process is killed (``SIGKILL``,
so it cannot shut its pool down) leaves no worker computing behind.  Oracle: the process table."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split()[2] == "Z")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the process table of /proc and ps --ppid")
def test_killing_a_parallel_run_leaves_no_worker_behind(tmp_path):
    code = ("from hybobs_opt import ProcessExecutor, analyse_observability, get_example\n"
            "import time\n"
            "ex = ProcessExecutor(2)\n"
            "print('started', flush=True)\n"
            "analyse_observability(get_example('powertrain5').build(), 9, executor=ex)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, cwd=REPO,
                            env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert proc.stdout.readline().strip() == "started"
    workers: list[int] = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(workers) < 2:
        workers = _children(proc.pid)
        time.sleep(0.2)
    assert len(workers) >= 2, "the pool did not start"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.2)
    assert not any(_alive(w) for w in workers), [w for w in workers if _alive(w)]
