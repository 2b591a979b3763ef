"""What every benchmark JSON records about the machine and the package versions."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path


def machine() -> dict:
    """Platform, CPU model, core count, Python version and the load average at start."""
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {"platform": platform.platform(), "machine": platform.machine(), "cpu": cpu, "cpu_count": os.cpu_count(),
            "python": platform.python_version(), "load_average_at_start": list(load) if load else None}


def git_state(measured: str) -> dict:
    """The commit a run measured, and the uncommitted changes under ``measured`` (a folder of the
    repository, e.g. ``"hybobs_opt/geometry"``) at that moment: the working tree may be shared.

    Returns ``{"head": ..., "uncommitted_in_<measured with / as _>": [...]}`` (``None`` values
    when git cannot be run).
    """
    root = Path(__file__).resolve().parents[1]
    key = "uncommitted_in_" + measured.replace("/", "_")
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", measured], cwd=root,
                               capture_output=True, text=True, timeout=10).stdout.splitlines()
    except (OSError, subprocess.SubprocessError):
        return {"head": None, key: None}
    return {"head": head, key: [ln.strip() for ln in dirty]}


def versions(packages) -> dict:
    """Installed versions of ``packages`` (``None`` when absent)."""
    out = {}
    for pkg in packages:
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out


def json_default(o):
    """``json.dumps(..., default=json_default)``: numpy integers, floats, booleans and arrays as JSON."""
    import numpy as np

    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(type(o).__name__)
