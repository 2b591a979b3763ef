"""Solver text written by native code never reaches stdout (``hybobs_opt._native_output``).

HiGHS 1.16 prints a banner to file descriptor 1 from C++ when a ``highspy.Highs`` is built, before
``output_flag`` can be set; the pinned 1.15 does not.  These tests make every solver constructor the
package calls print through the C library (``printf``, buffered when stdout is a pipe, and
``write(2, ...)``), in a child process whose stdout is a pipe, and check that ``--json`` output is
still one JSON document: they fail if any site that builds a solver is left uncaptured.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
INPUTS = ROOT / "tests" / "app" / "cli_json_golden" / "inputs"
ROTATION = ROOT / "examples" / "models" / "bemporad_morari_rotation.toml"

pytestmark = pytest.mark.skipif(os.name == "nt", reason="uses the C library's printf through ctypes")

#: Replaces the solver constructors the package calls with ones that first print like a native banner.
_NOISY_SOLVERS = textwrap.dedent("""
    import ctypes, os, sys
    _libc = ctypes.CDLL(None)
    def _banner(name):
        _libc.printf(("BANNER-OUT " + name + "\\n").encode())
        os.write(2, ("BANNER-ERR " + name + "\\n").encode())
        sys.stdout.write("BANNER-PY " + name + "\\n")

    import highspy
    _Highs = highspy.Highs
    class _NoisyHighs(_Highs):
        def __init__(self, *args, **kwargs):
            _banner("highspy")
            super().__init__(*args, **kwargs)
    highspy.Highs = _NoisyHighs

    import casadi
    for _name in ("conic", "nlpsol"):
        def _make(original, name):
            def noisy(*args, **kwargs):
                _banner("casadi." + name)
                return original(*args, **kwargs)
            return noisy
        setattr(casadi, _name, _make(getattr(casadi, _name), _name))
""")


def _run(script: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=600)


def test_printf_write_and_python_prints_are_captured_and_logged():
    proc = _run(textwrap.dedent("""
        import ctypes, logging, os, sys
        records = []
        class Keep(logging.Handler):
            def emit(self, record):
                records.append(record.getMessage())
        logger = logging.getLogger("hybobs_opt.solvers")
        logger.addHandler(Keep()); logger.setLevel(logging.DEBUG)
        from hybobs_opt._native_output import captured_native_output
        print("before", flush=True)
        with captured_native_output("a noisy solver"):
            ctypes.CDLL(None).printf(b"C-BUFFERED\\n")   # no newline flush: stdout is a pipe
            os.write(2, b"ON-FD-2\\n")
            print("PY-PRINT")
            with captured_native_output("nested"):
                os.write(1, b"NESTED\\n")
        print("after")
        sys.stderr.write("|".join(records))
    """))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "before\nafter\n"
    log = proc.stderr
    assert log.startswith("a noisy solver wrote to stdout/stderr:")
    for text in ("C-BUFFERED", "ON-FD-2", "PY-PRINT", "NESTED"):
        assert text in log
    assert "nested wrote" not in log  # the inner context adds no second record


def test_output_after_the_block_is_not_captured():
    proc = _run(textwrap.dedent("""
        import ctypes, os
        from hybobs_opt._native_output import captured_native_output
        with captured_native_output():
            pass
        os.write(1, b"fd1\\n")
        libc = ctypes.CDLL(None); libc.printf(b"printf\\n"); libc.fflush(None)
        print("python")
    """))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "fd1\nprintf\npython\n"


@pytest.mark.parametrize("argv", [
    ["observe", str(ROTATION), "--data", str(INPUTS / "rotation_sine.csv"), "-T", "3", "--observer", "milp", "--json"],
    ["observe", str(ROTATION), "--data", str(INPUTS / "rotation_sine.csv"), "-T", "3", "--observer", "set_membership",
     "--noise-bound", "y=0.01", "--json"],
], ids=["milp-highspy", "set-membership-highspy"])
def test_json_stays_json_when_solvers_print_banners(argv):
    proc = _run(_NOISY_SOLVERS + textwrap.dedent(f"""
        import sys
        from hybobs_opt.cli import main
        sys.exit(main({argv!r}))
    """))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "BANNER" not in proc.stdout
    document = json.loads(proc.stdout)  # exactly one JSON document
    assert isinstance(document, dict) and "error" not in document
    assert "BANNER" not in proc.stderr  # captured, not moved to stderr


@pytest.mark.parametrize("norm, solver", [("2", "casadi-daqp"), ("2", "bonmin"), ("1", "cbc"), ("1", "sequences")])
def test_mhe_backends_build_their_solvers_quietly(norm, solver):
    proc = _run(_NOISY_SOLVERS + textwrap.dedent(f"""
        import numpy as np
        from hybobs_opt import MHEObserver, load_model, read_log
        system = load_model({str(ROTATION)!r})
        log = read_log({str(INPUTS / "rotation_sine.csv")!r}, system)
        observer = MHEObserver(system, T=3, norm={norm!r}, solver={solver!r})
        for k in range(4):
            observer.step(log.U[k], log.Y[k])
        print("DONE")
    """))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout == "DONE\n"
    assert "BANNER" not in proc.stderr


def test_the_noisy_constructors_do_print_when_not_captured():
    """The stand-in banners are real: built outside the package they reach stdout and stderr."""
    proc = _run(_NOISY_SOLVERS + "h = highspy.Highs()\n")
    assert proc.returncode == 0, proc.stderr
    assert "BANNER-OUT highspy" in proc.stdout and "BANNER-PY highspy" in proc.stdout
    assert "BANNER-ERR highspy" in proc.stderr
