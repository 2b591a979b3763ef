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


def test_a_horizon_beyond_the_budget_is_refused_with_its_prediction_before_any_lp():
    """``regions powertrain3 -T 99`` ran past 180 s; now refused in seconds, naming the prediction
    and the option that overrides it.  Oracle: the regions counted at T = 7 and 8 (exact), whose
    growth the prediction extrapolates, and the wall time."""
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "hybobs_opt.cli", "regions", "powertrain3", "-T", "99", "--no-cache"],
                       capture_output=True, text=True, timeout=120, cwd=REPO)
    assert time.perf_counter() - t0 < 30
    assert r.returncode == 2 and "--max-lps" in r.stderr and "pair LPs predicted" in r.stderr
    from hybobs_opt import enumerate_modes, get_example
    from hybobs_opt.regions.enumeration import predict_analysis_cost

    plant = get_example("powertrain3").build()
    pred = predict_analysis_cost(plant, 8)
    actual = len(enumerate_modes(plant, 8).regions)
    assert 0.5 * actual <= pred["regions"] <= 2.0 * actual  # the extrapolation is within 2x at T = 8
