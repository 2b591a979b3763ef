"""Install the package as a user of PyPI would, and check that its JSON and first example still work.

CI pins every dependency (``constraints.txt``); users who ``pip install hybobs_opt`` get the newest
versions the package's own bounds allow.  This check (CI's plain-pip job):

1. builds the wheel with plain ``pip wheel`` (no ``make``, no constraints file);
2. installs it with its ``test`` and ``models`` extras into a fresh virtual environment, with the
   newest allowed versions, and prints the versions that matter;
3. copies the tests, the examples and the pytest configuration (not the package) into a scratch
   directory, so the tests import the installed wheel, and checks that they do;
4. runs the README's first Python example and the CLI JSON tests (every command's ``--json`` output
   against its golden record, and the solver-banner tests of ``tests/unit/core/test_native_output.py``);
5. builds the wheel and the sdist with ``python -m build`` and follows the README's sdist recipe:
   unpack it, ``pip install -c constraints.txt '.[test]'`` into another fresh environment, and run
   ``python -m pytest tests/unit/core`` there (``--no-sdist`` skips this part).

Exit status 0 when all pass; otherwise the failing step's output and status 1.

Run: ``python3 scripts/check_plain_pip.py [--root CHECKOUT] [--workdir DIR] [--keep]``
(``--root`` checks another checkout, e.g. an older commit, with this script's steps).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

#: Distributions whose installed versions the check prints (the solvers and numerics the answers rest on).
REPORTED = ("numpy", "scipy", "cvxpy", "clarabel", "cvxopt", "osqp", "casadi", "highspy", "daqp", "numba", "matplotlib",
            "pycddlib-standalone", "pytest")

#: The tests run against the installed wheel.
TESTS = ["tests/app/test_cli_json_golden.py", "tests/unit/core/test_native_output.py"]


def _step(title: str, argv: list[str], cwd: Path, env: dict | None = None, timeout: float = 3600) -> str:
    print(f"== {title}: {' '.join(map(str, argv))}", flush=True)
    t0 = time.perf_counter()
    proc = subprocess.run([str(a) for a in argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    print(f"   {time.perf_counter() - t0:.1f} s, exit status {proc.returncode}", flush=True)
    if proc.returncode != 0:
        print(proc.stdout[-6000:])
        print(proc.stderr[-6000:], file=sys.stderr)
        raise SystemExit(f"plain-pip check failed at: {title}")
    return proc.stdout


def readme_example(readme: Path) -> str:
    """The first ``python`` code block after the heading that contains "example" (the README's first example)."""
    text = readme.read_text(encoding="utf-8")
    heading = re.search(r"^##[^\n]*example[^\n]*$", text, flags=re.IGNORECASE | re.MULTILINE)
    if heading is None:
        raise SystemExit(f"{readme}: no '## ... example' heading")
    block = re.search(r"^```python\n(.*?)^```", text[heading.end():], flags=re.DOTALL | re.MULTILINE)
    if block is None:
        raise SystemExit(f"{readme}: no python code block after {heading.group(0)!r}")
    return block.group(1)


def check_sdist(python: str, py: Path, root: Path, work: Path) -> None:
    """``python -m build`` gives a wheel and an sdist, and the README's sdist recipe passes."""
    import tarfile

    built = work / "build"
    shutil.rmtree(built, ignore_errors=True)
    _step("install build", [py, "-m", "pip", "install", "--quiet", "build"], cwd=work)
    _step("python -m build", [py, "-m", "build", "--outdir", built, root], cwd=work)
    sdists, wheels = sorted(built.glob("hybobs_opt-*.tar.gz")), sorted(built.glob("hybobs_opt-*.whl"))
    if len(sdists) != 1 or len(wheels) != 1:
        raise SystemExit(f"python -m build made {[p.name for p in built.iterdir()]}, not one sdist and one wheel")
    unpacked = work / "sdist"
    shutil.rmtree(unpacked, ignore_errors=True)
    with tarfile.open(sdists[0]) as tar:
        tar.extractall(unpacked, filter="data")
    src = next(unpacked.iterdir())
    venv = work / "venv-sdist"
    shutil.rmtree(venv, ignore_errors=True)
    _step("fresh virtual environment for the sdist", [python, "-m", "venv", venv], cwd=work)
    spy = venv / ("Scripts" if os.name == "nt" else "bin") / "python"
    _step("the sdist recipe: pip install -c constraints.txt '.[test]'",
          [spy, "-m", "pip", "install", "--quiet", "-c", "constraints.txt", ".[test]"], cwd=src)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["OPENBLAS_NUM_THREADS"] = env.get("OPENBLAS_NUM_THREADS", "1")
    out = _step("the sdist recipe: python -m pytest tests/unit/core -q",
                [spy, "-m", "pytest", "tests/unit/core", "-q", "-p", "no:cacheprovider"], cwd=src, env=env)
    print("   " + out.strip().splitlines()[-1], flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, default=HERE, help="the checkout to build and test (default: this one)")
    parser.add_argument("--workdir", type=Path, default=None, help="scratch directory (default: a new temporary one)")
    parser.add_argument("--keep", action="store_true", help="keep the scratch directory")
    parser.add_argument("--python", default=sys.executable, help="the Python that builds the wheel and the venv")
    parser.add_argument("--no-sdist", action="store_true", help="skip python -m build and the sdist recipe")
    args = parser.parse_args(argv)
    root = args.root.resolve()
    work = (args.workdir or Path(tempfile.mkdtemp(prefix="hybobs-plain-pip-"))).resolve()
    work.mkdir(parents=True, exist_ok=True)
    try:
        dist, venv, src = work / "dist", work / "venv", work / "src"
        shutil.rmtree(dist, ignore_errors=True)
        had_build_dir = (root / "build").exists()
        _step("build the wheel", [args.python, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", dist, root], cwd=work)
        if not had_build_dir:  # setuptools builds in the checkout's build/: leave the checkout as it was
            shutil.rmtree(root / "build", ignore_errors=True)
        wheel = next(dist.glob("hybobs_opt-*.whl"))
        shutil.rmtree(venv, ignore_errors=True)
        _step("fresh virtual environment", [args.python, "-m", "venv", venv], cwd=work)
        py = venv / ("Scripts" if os.name == "nt" else "bin") / "python"
        _step("upgrade pip", [py, "-m", "pip", "install", "--quiet", "--upgrade", "pip"], cwd=work)
        _step("install the wheel, newest allowed versions, no constraints",
              [py, "-m", "pip", "install", "--quiet", f"{wheel}[test,models]"], cwd=work)
        freeze = _step("installed versions", [py, "-m", "pip", "list", "--format=freeze"], cwd=work)
        versions = dict(line.split("==", 1) for line in freeze.splitlines() if "==" in line)
        print("   " + ", ".join(f"{name} {versions.get(name, '-')}" for name in REPORTED), flush=True)

        shutil.rmtree(src, ignore_errors=True)
        src.mkdir()
        for name in ("tests", "examples"):
            shutil.copytree(root / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        for name in ("pyproject.toml", "README.md"):
            shutil.copy2(root / name, src / name)
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
        env["OPENBLAS_NUM_THREADS"] = env.get("OPENBLAS_NUM_THREADS", "1")
        where = _step("the tests import the installed wheel",
                      [py, "-c", "import hybobs_opt, sys; print(hybobs_opt.__file__)"], cwd=src, env=env).strip()
        if "site-packages" not in where:
            raise SystemExit(f"hybobs_opt was imported from {where}, not from the installed wheel")
        _step("compile the kernels", [py, "-m", "hybobs_opt._warm_up"], cwd=src, env=env)

        example = src / "readme_example.py"
        example.write_text(readme_example(src / "README.md"), encoding="utf-8")
        out = _step("the README's first example", [py, example], cwd=src, env=env)
        print("   " + out.strip().replace("\n", "\n   "), flush=True)

        tests = [t for t in TESTS if (src / t).is_file()]
        if len(tests) < len(TESTS):  # an older checkout (--root) may predate some of them
            print(f"   not in this checkout: {sorted(set(TESTS) - set(tests))}", flush=True)
        out = _step("the CLI JSON tests", [py, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "2",
                                           "--dist", "worksteal", *tests], cwd=src, env=env)
        print("   " + out.strip().splitlines()[-1], flush=True)
        if not args.no_sdist:
            check_sdist(args.python, py, root, work)
        print("plain-pip check passed", flush=True)
        return 0
    finally:
        if not args.keep and args.workdir is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
