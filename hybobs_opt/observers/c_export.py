"""The lookup-table deadbeat observer (paper 002, Algorithm 4.1) exported as self-contained C99.

:func:`export_lookup_c` writes ``NAME.h``, ``NAME.c`` and ``NAME_driver.c`` for a
:class:`~hybobs_opt.observers.lookup.LookupObserver`: the tables that its compiled step
(:mod:`hybobs_opt.observers._lookup_kernels`) evaluates become ``static const`` arrays, the
observer's state a struct, and ``NAME_step(&state, u, y, &estimate)`` is that step written in C
with the same operations in the same order:

* the sample checks (NaN/Inf; an input outside ``U`` by more than ``LOOKUP_INPUT_BOUND_TOL``):
  flag ``fallback`` with the same reason codes (:data:`~hybobs_opt.observers.lookup.REASONS`);
* step 2.1's open-loop prediction ``f_pwa(x(t-1), u(t-1))`` at the estimate clipped to the
  state box;
* the candidates of eq. (13) (``C_i^+``), the output equality of eq. (12) (residual rows) and
  the membership tests ``[x_i; U_t] in P_i`` of eq. (14) (H-representations over the data
  window, strict on guard rows, closed on the rows of ``U``): one table product per region;
* the ``B~_T`` test of eq. (15) on a unique candidate, then the propagation of the window-start
  state to the current sample through the region's affine map.

The ``B~_T`` test is the observer's own.  With ``b_tilde="project"`` (or given polytopes) it is
a point-in-union test over the exported H-representations.  With the default pair pieces
(``b_tilde=None``) the exported code screens the candidate against every piece ``Proj_x(R_ij)``
with the same rows as the kernel's screen (:func:`~hybobs_opt.observers._lookup_kernels.pair_screen`)
and decides each piece that survives by the same linear programme as the Python observer
(``max t`` s.t. ``A v + t <= b_0 + B_1 x``, ``t <= SLACK_CAP``; inside when ``t > -LOOKUP_MEMBERSHIP_TOL``),
solved by a dense simplex on the piece's tableau (no library): free variables enter first and
never leave, then Bland's rule, so it ends without cycling; it stops as soon as a feasible point
has ``t > -tol``.  The Python observer certifies the same decision (DAQP with dual bounds, HiGHS
when undecided) and caches cuts that spare it LPs, which changes no answer.  The answers can
differ only when the optimum lies within rounding of ``-LOOKUP_MEMBERSHIP_TOL``, or when an LP
reaches the pivot limit :data:`~hybobs_opt.defaults.C_EXPORT_LP_PIVOTS_PER_LP` (then the C code
answers "in ``B~_T``": flag ``unobservable``, never a wrong reconstruction, and counts it in ``state.n_lp_limits``).

The header comment prints the table bytes (flash) and a bound on the multiply-adds of one step,
counted from the tables: every region's rows, every screen row, and every piece's LP at the pivot
limit.  No dynamic memory, no library beyond ``math.h``.

``float32=True`` writes the tables as ``float`` and computes in ``float``.  Tolerances below the
resolution of single precision are raised to the ``C_EXPORT_F32_*`` values of
:mod:`hybobs_opt.tolerances` (the double export uses the observer's own).
"""

from __future__ import annotations

import keyword
import os
import re
from dataclasses import dataclass
from pathlib import Path
from string import Template
from typing import Any

import numpy as np

from .._output_files import write_output_text
from ..defaults import C_EXPORT_LP_PIVOTS_PER_LP
from ..errors import ModelError
from ..limits import MAX_EXPORT_TABLE_BYTES
from ..tolerances import (
    C_EXPORT_F32_INPUT_BOUND_TOL,
    C_EXPORT_F32_INTERIOR_MARGIN,
    C_EXPORT_F32_LP_COST_TOL,
    C_EXPORT_F32_LP_PIVOT_TOL,
    C_EXPORT_F32_MAX_ROUNDING,
    C_EXPORT_F32_MEMBERSHIP_TOL,
    C_EXPORT_F32_OUTPUT_RTOL,
    C_EXPORT_F32_SAME_STATE_TOL,
    C_EXPORT_LP_COST_TOL,
    C_EXPORT_LP_PIVOT_TOL,
    LOOKUP_INPUT_BOUND_TOL,
    LOOKUP_MEMBERSHIP_TOL,
    LOOKUP_SAME_STATE_TOL,
    SLACK_CAP,
)
from . import _lookup_kernels as K


#: Bytes of a C ``int`` (index tables) on the targets the export is meant for (ILP32, LP64).
INT_BYTES = 4

_C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef union unsigned void
volatile while _Bool _Complex _Imaginary""".split())


@dataclass(frozen=True)
class CExport:
    """What :func:`export_lookup_c` wrote and what the exported step costs.

    Parameters
    ----------
    name : str
        The C prefix of every symbol (``NAME_step``, ``NAME_state`` ...) and of the file names.
    directory : Path
        Where the files are.
    header, source, driver : Path
        ``NAME.h``, ``NAME.c`` and the CSV replay driver ``NAME_driver.c``.
    float32 : bool
        ``float`` tables and arithmetic instead of ``double``.
    table_bytes : int
        Bytes of the ``static const`` tables (flash).
    state_bytes : int
        Bytes of ``NAME_state`` (RAM), counted from its members (the compiler may pad it).
    max_ops : int
        Bound on the multiply-adds of one step (a division counts as one).
    ops : dict
        ``max_ops`` by part of the step (``sample_checks``, ``prediction``, ``window``,
        ``propagation``, ``btilde_screen``, ``btilde_lps``).
    sizes : dict
        Dimensions of the tables (regions, rows, pieces ...).
    btilde_test : str
        ``"pairs"`` (screen and LPs) or ``"polytopes"`` (point-in-union).
    tolerances : dict
        The tolerances written into the code.
    float32_rounding : float or None
        With ``float32``: a bound on the single-precision rounding of the candidates of eq. (13),
        as a fraction of each state's half-range (largest over regions, Euclidean over states).

    See Also
    --------
    export_lookup_c : Returns one.
    check_build : Compiles it.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import export_lookup_c
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     export = export_lookup_c(LookupObserver(analysis), tmp, name="pt3")
    ...     print(export.name, export.float32, export.max_ops > 0)
    ...     print("-std=c99" in export.compile_command)
    ...
    pt3 False True
    True
    """

    name: str
    directory: Path
    header: Path
    source: Path
    driver: Path
    float32: bool
    table_bytes: int
    state_bytes: int
    max_ops: int
    ops: dict
    sizes: dict
    btilde_test: str
    tolerances: dict
    float32_rounding: float | None = None

    @property
    def compile_command(self) -> str:
        """A command line that builds the replay driver (run in :attr:`directory`)."""
        return f"cc -std=c99 -O2 {self.source.name} {self.driver.name} -lm -o {self.name}_driver"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (paths as strings).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"name": self.name, "directory": str(self.directory),
                "files": {"header": str(self.header), "source": str(self.source), "driver": str(self.driver)},
                "float32": self.float32, "table_bytes": self.table_bytes, "state_bytes": self.state_bytes,
                "max_ops": self.max_ops, "ops": dict(self.ops), "sizes": dict(self.sizes),
                "btilde_test": self.btilde_test, "tolerances": dict(self.tolerances),
                "float32_rounding": self.float32_rounding, "compile": self.compile_command}


def export_targets(out_dir, name: str = "hybobs_lookup", *, overwrite: bool = False) -> tuple[Path, Path, Path]:
    """The three files :func:`export_lookup_c` writes, checked before any work: ``out_dir`` is a
    directory or missing, no target is a symbolic link, and none exists unless ``overwrite``.

    Returns
    -------
    header, source, driver : Path
        ``NAME.h``, ``NAME.c`` and ``NAME_driver.c`` in ``out_dir``.

    Raises
    ------
    ModelError
        Naming ``out_dir`` and the offending file.

    See Also
    --------
    export_lookup_c : Writes the three files.

    Examples
    --------
    >>> import tempfile
    >>> from hybobs_opt.observers import export_targets
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     print([p.name for p in export_targets(tmp, "obs")])
    ...
    ['obs.h', 'obs.c', 'obs_driver.c']
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ModelError("out_dir", "a directory (created if missing)", f"{str(out)!r}, an existing file")
    ancestor = out
    while not ancestor.exists() and ancestor.parent != ancestor:
        ancestor = ancestor.parent
    if not ancestor.is_dir():  # the directory could not be created below a file
        raise ModelError("out_dir", "a directory (created if missing)", f"{str(out)!r}: {str(ancestor)!r} is a file")
    targets = (out / f"{name}.h", out / f"{name}.c", out / f"{name}_driver.c")
    for path in targets:
        if path.is_symlink():
            raise ModelError("out_dir", "no symbolic link among the files to write (a link is never followed)",
                             f"{str(path)!r}, a link to {os.readlink(path)!r}")
        if path.exists() and not overwrite:
            raise ModelError("out_dir", "a directory without the files to write (or overwrite=True / --force to "
                             "replace them)", f"{str(path)!r} exists")
        if path.exists() and not path.is_file():
            raise ModelError("out_dir", "regular files only at the names to write", f"{str(path)!r}")
    return targets


def _write_new(path: Path, text: str) -> None:
    """Write ``text`` to a new file at ``path`` (an existing one is removed first): ``O_EXCL`` and
    ``O_NOFOLLOW`` make a link planted since the check fail instead of being followed."""
    if path.exists() or path.is_symlink():
        path.unlink()
    write_output_text(path, text, exclusive=True, encoding="ascii")


def export_lookup_c(observer, out_dir, *, name: str = "hybobs_lookup", float32: bool = False,
                    overwrite: bool = False) -> CExport:
    """Write the lookup-table observer (paper 002, Algorithm 4.1) as self-contained C99.

    ``NAME.h`` declares ``NAME_state``, ``NAME_estimate``, ``NAME_reset(&s, x0)`` (``x0 = NULL``:
    the centre of the state box, as :meth:`LookupObserver.reset`) and
    ``NAME_step(&s, u, y, &e)``, which returns the flag code (0 ``observable``, 1
    ``unobservable``, 2 ``fallback``, 3 ``warming_up``) and fills the estimate, the mode and
    the reason code exactly as :meth:`LookupObserver.step` does (see the module docstring for
    the one place where the answers can differ).  ``NAME.c`` holds the tables and the step;
    ``NAME_driver.c`` replays a CSV log (columns named by the system's inputs and outputs) and
    writes ``[t,] states..., mode, flag, reason`` per sample, optionally with the time of each
    step (``clock_gettime``).

    Parameters
    ----------
    observer : LookupObserver or ObservabilityAnalysis
        The observer to export (``variant="table"``), or the result of Algorithm 3.1 from which
        the default observer ``LookupObserver(analysis)`` is built.
    out_dir : str or Path
        Directory of the three files (created if missing).
    name : str
        C identifier: the prefix of every exported symbol and of the file names.
    float32 : bool
        Write ``float`` tables and compute in ``float`` (tolerances raised to single precision).
    overwrite : bool, default False
        Replace the three files if they exist (by new files: a symbolic link is never followed).
        Without it an existing file is an error, raised before any work (:func:`export_targets`).

    Returns
    -------
    CExport
        The paths, the table bytes and the bound on the multiply-adds of one step.

    Raises
    ------
    ModelError
        ``observer`` is neither, or is the ``"exact"`` variant (its LPs on the data are not
        exported); ``name`` is no C identifier; ``out_dir`` is an existing file; a table holds a
        number that is not finite (in ``float`` for ``float32``); or the tables exceed
        :data:`~hybobs_opt.limits.MAX_EXPORT_TABLE_BYTES` (field ``tables``).

    See Also
    --------
    CExport : What it returns.
    check_build : Compiles and replays the export.
    LookupObserver : The observer exported.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import export_lookup_c
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     export = export_lookup_c(LookupObserver(analysis), tmp, name="pt3")
    ...     print(export.header.name, export.source.name, export.table_bytes > 0)
    ...
    pt3.h pt3.c True
    """
    from ..regions.observability import ObservabilityAnalysis  # lazy: regions sits beside observers
    from .lookup import LookupObserver

    if isinstance(observer, ObservabilityAnalysis):
        observer = LookupObserver(observer)
    if not isinstance(observer, LookupObserver):
        raise ModelError("observer", "a LookupObserver or an ObservabilityAnalysis (Algorithm 3.1)",
                         f"{type(observer).__name__}")
    if observer.variant != "table" or observer.btilde_test not in ("pairs", "polytopes"):
        raise ModelError("observer", "the lookup observer with the table test of B~_T (variant='table'): the LPs of the "
                         "'exact' variant are not exported", f"variant {observer.variant!r}")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,40}", name) or name in _C_KEYWORDS \
            or keyword.iskeyword(name):
        raise ModelError("name", "a C identifier of at most 41 characters (letters, digits, '_'; not a keyword)", repr(name))
    if not isinstance(float32, bool):
        raise ModelError("float32", "True or False", repr(float32))
    if not isinstance(overwrite, bool):
        raise ModelError("overwrite", "True or False", repr(overwrite))
    out = Path(out_dir)
    header, source, driver = export_targets(out, name, overwrite=overwrite)
    data = _Tables(observer, float32)
    if float32 and not data.float32_rounding <= C_EXPORT_F32_MAX_ROUNDING:
        raise ModelError("float32", f"a system whose candidates single precision resolves to {C_EXPORT_F32_MAX_ROUNDING:.0%} "
                         "of each state's range (hybobs_opt.tolerances.C_EXPORT_F32_MAX_ROUNDING); export it in double "
                         "precision", f"a rounding bound of {data.float32_rounding:.3g} of the range for "
                         f"{observer.system.name!r} at T = {observer.T} (the pseudo-inverses C_i^+ amplify the rounding "
                         "of the outputs)")
    if data.table_bytes > MAX_EXPORT_TABLE_BYTES:
        raise ModelError("tables", f"tables of at most {MAX_EXPORT_TABLE_BYTES:,} bytes "
                         "(hybobs_opt.limits.MAX_EXPORT_TABLE_BYTES)",
                         f"{data.table_bytes:,} bytes for {observer.system.name!r} at T = {observer.T}")
    out.mkdir(parents=True, exist_ok=True)
    export_targets(out, name, overwrite=overwrite)  # again: the tables took a while
    text = _Writer(observer, data, name)
    for path, body in ((header, text.header()), (source, text.source()), (driver, text.driver())):
        _write_new(path, body)
    return CExport(name, out, header, source, driver, float32, data.table_bytes, data.state_bytes, data.max_ops,
                   data.ops, data.sizes, observer.btilde_test, data.tolerances, data.float32_rounding)


#: Flags of the build check: the code must compile without a warning as strict C99.
BUILD_FLAGS: tuple[str, ...] = ("-std=c99", "-Wall", "-Werror", "-pedantic", "-O2")


def check_build(export: CExport, system, *, compiler: str | None = None, timeout: float = 600.0) -> dict:
    """Compile an export with :data:`BUILD_FLAGS` and replay a one-sample log through its driver.

    The build happens in a temporary directory (nothing is added to :attr:`CExport.directory`).

    Parameters
    ----------
    export : CExport
        What :func:`export_lookup_c` wrote.
    system : PWASystem
        The exported observer's system (its input and output names make the log's header).
    compiler : str, optional
        The C compiler; default the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``.
    timeout : float, default 600
        Seconds allowed to each of the compile and the run.

    Returns
    -------
    dict
        ``compiler`` (``None`` when none was found: nothing was checked), ``flags``, ``built``,
        ``ran`` and ``seconds``.

    Raises
    ------
    BuildError
        When the code does not compile, or the driver fails on the log.

    See Also
    --------
    export_lookup_c : The export it builds.
    BUILD_FLAGS : The compiler flags.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import check_build, export_lookup_c
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     export = export_lookup_c(LookupObserver(analysis), tmp, name="pt3")
    ...     report = check_build(export, plant)       # needs a C compiler (cc)
    ...
    >>> report["built"], report["ran"], report["flags"]
    (True, True, ['-std=c99', '-Wall', '-Werror', '-pedantic', '-O2'])
    """
    import shutil
    import subprocess
    import tempfile
    import time

    from ..errors import BuildError

    cc = compiler or next((c for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
    if cc is None or shutil.which(cc) is None:
        return {"compiler": None, "flags": list(BUILD_FLAGS), "built": False, "ran": False, "seconds": 0.0}
    what = f"the exported C in {str(export.directory)!r}"
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hybobs_build_") as tmp:
        exe = Path(tmp) / "driver"
        try:
            r = subprocess.run([cc, *BUILD_FLAGS, str(export.source), str(export.driver), "-lm", "-o", str(exe)],
                               capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise BuildError(what, "compile", f"no answer from {cc} within {timeout:g} s") from None
        if r.returncode != 0:
            raise BuildError(what, "compile", r.stderr or r.stdout)
        half, centre = system.scales()
        u = centre[system.n:system.n + system.m]
        log = Path(tmp) / "log.csv"
        log.write_text(",".join(["t", *system.input_names, *system.output_names]) + "\n"
                       + ",".join(["0", *(repr(float(v)) for v in u), *(["0"] * system.p)]) + "\n")
        est = Path(tmp) / "estimates.csv"
        try:
            r = subprocess.run([str(exe), str(log), str(est)], capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise BuildError(what, "run", f"the driver did not finish a one-sample log within {timeout:g} s") from None
        lines = est.read_text().splitlines() if est.exists() else []
        if r.returncode != 0 or len(lines) != 2:
            raise BuildError(what, "run", (r.stderr or r.stdout) + f" (exit {r.returncode}, {len(lines)} lines written)")
    return {"compiler": cc, "flags": list(BUILD_FLAGS), "built": True, "ran": True, "seconds": time.perf_counter() - t0}


# ---------------------------------------------------------------------------------------- tables
class _Tables:
    """The observer's kernel tables as the flat arrays of the C source, their sizes and the step's cost."""

    def __init__(self, obs, float32: bool):
        if not hasattr(obs, "_tables"):
            obs.reset()
        self.float32 = float32
        self.real = np.float32 if float32 else np.float64
        self.real_bytes = 4 if float32 else 8
        n, m, p, T = obs.n, obs.m, obs.p, obs.T
        self.n, self.m, self.p, self.T = n, m, p, T
        Kr = int(obs._K)
        R, D = obs._table.shape
        self.arrays: list[tuple[str, str, np.ndarray]] = []  # (C name, "real" or "int", flat array)
        mthr = np.asarray(obs._mthr, dtype=float)
        if float32:
            mthr = np.where(mthr > 0, C_EXPORT_F32_INPUT_BOUND_TOL, -C_EXPORT_F32_INTERIOR_MARGIN)
            tol = {"output_rtol": max(obs.output_rtol, C_EXPORT_F32_OUTPUT_RTOL),
                   "same_state_tol": C_EXPORT_F32_SAME_STATE_TOL, "membership_tol": C_EXPORT_F32_MEMBERSHIP_TOL,
                   "input_bound_tol": C_EXPORT_F32_INPUT_BOUND_TOL, "interior_margin": C_EXPORT_F32_INTERIOR_MARGIN,
                   "lp_pivot_tol": C_EXPORT_F32_LP_PIVOT_TOL, "lp_cost_tol": C_EXPORT_F32_LP_COST_TOL}
        else:
            tol = {"output_rtol": float(obs.output_rtol), "same_state_tol": LOOKUP_SAME_STATE_TOL,
                   "membership_tol": LOOKUP_MEMBERSHIP_TOL, "input_bound_tol": LOOKUP_INPUT_BOUND_TOL,
                   "interior_margin": float(-mthr[mthr < 0][0]) if np.any(mthr < 0) else None,
                   "lp_pivot_tol": C_EXPORT_LP_PIVOT_TOL, "lp_cost_tol": C_EXPORT_LP_COST_TOL}
        tol["slack_cap"] = SLACK_CAP
        self.tolerances = tol
        self.float32_rounding = _float32_rounding(obs) if float32 else None
        self._add("TAB", obs._table)
        self._add("OFF", obs._offset)
        self._add("MTHR", mthr)
        self._add("MSTART", obs._mstarts, "int")
        self._add("SX", obs._sx)
        self._add("PL", obs._Pl)
        self._add("GL", obs._Gl)
        self._add("PLC", obs._pl)
        self._add("LASTMODE", obs._last_mode, "int")
        self._add("MODE_A", obs._modeA)
        self._add("MODE_B", obs._modeB)
        self._add("MODE_C", obs._modea)
        self._add("GUARD", obs._guard)
        self._add("GUARD_RHS", obs._guard_rhs)
        self._add("GUARD_START", obs._guard_starts, "int")
        n_in = int(obs._in_b.shape[0])
        self._add("IN_A", obs._in_A[:, :m] if n_in else np.zeros(0))
        self._add("IN_B", obs._in_b)
        self._add("XLO", obs._x_lo)
        self._add("XHI", obs._x_hi)
        self._add("XDEF", obs.analysis.enumeration.centre[:n])
        n_modes = int(obs._modeA.shape[0])
        sizes = {"n": n, "m": m, "p": p, "T": T, "n_regions": Kr, "table_rows": int(R), "window_length": int(D),
                 "membership_rows": int(mthr.shape[0]), "n_modes": n_modes, "guard_rows": int(obs._guard.shape[0]),
                 "input_rows": n_in, "propagation_columns": int(obs._Gl.shape[2])}
        ops = {"sample_checks": n_in * m,
               "prediction": int(obs._guard.shape[0]) * (n + m) + n * (n + m),
               "window": int(R) * int(D),
               "propagation": n * (n + int(obs._Gl.shape[2]))}
        lp_ops = 0
        if obs.btilde_test == "pairs":
            pp = obs._pairs
            shapes = np.array([A.shape for A, _, _ in pp.lp], dtype=np.int64).reshape(-1, 2)
            rows, cols = shapes[:, 0], shapes[:, 1]
            self._add("XC", pp.cx)
            self._add("PSX", pp.sx)
            self._add("EX_A", pp.ex_A)
            self._add("EX_B", pp.ex_b)
            self._add("EX_START", pp.ex_starts, "int")
            self._add("LP_ROWS", rows, "int")
            self._add("LP_COLS", cols, "int")
            self._add("LP_AOFF", np.concatenate([[0], np.cumsum(rows * cols)[:-1]]) if rows.size else np.zeros(0), "int")
            self._add("LP_ROFF", np.concatenate([[0], np.cumsum(rows)[:-1]]) if rows.size else np.zeros(0), "int")
            self._add("LP_A", np.concatenate([A.ravel() for A, _, _ in pp.lp]) if pp.lp else np.zeros(0))
            self._add("LP_B0", np.concatenate([b0 for _, b0, _ in pp.lp]) if pp.lp else np.zeros(0))
            self._add("LP_B1", np.vstack([B1 for _, _, B1 in pp.lp]) if pp.lp else np.zeros(0))
            nr, nc = rows + 1, cols + 1
            pivots = C_EXPORT_LP_PIVOTS_PER_LP * (rows + cols + 2)
            # per LP: b = b0 + B1 x, then per pivot the ratio test (nr divisions), the pivot row and
            # objective scaled (2 nc), every other row and the right-hand sides updated (nr nc)
            per_lp = rows * n + pivots * (nr + 2 * nc + nr * nc)
            lp_ops = int(np.sum(np.where(rows > 0, per_lp, 0)))
            ops["btilde_screen"] = 2 * n + int(pp.ex_A.shape[0]) * n
            self.lp_max_rows = int(rows.max()) if rows.size else 0
            self.lp_max_cols = int(cols.max()) if cols.size else 0
            sizes.update({"n_btilde_pieces": int(rows.size), "screen_rows": int(pp.ex_A.shape[0]),
                          "lp_rows": int(rows.sum()), "lp_max_rows": self.lp_max_rows, "lp_max_columns": self.lp_max_cols})
            self.n_pieces = int(rows.size)
        else:
            self._add("BT_A", obs._bt_A)
            self._add("BT_B", obs._bt_b)
            self._add("BT_START", obs._bt_starts, "int")
            ops["btilde_screen"] = int(obs._bt_A.shape[0]) * n
            self.lp_max_rows = self.lp_max_cols = 0
            self.n_pieces = int(obs._bt_starts.shape[0]) - 1
            sizes.update({"n_btilde_pieces": self.n_pieces, "btilde_rows": int(obs._bt_A.shape[0])})
        ops["btilde_lps"] = lp_ops
        self.ops = ops
        self.max_ops = int(sum(ops.values()))
        self.sizes = sizes
        self.counts = {"R": int(R), "D": int(D), "K": Kr, "RM": int(mthr.shape[0]), "Q": n_modes, "NI": n_in,
                       "GLC": int(obs._Gl.shape[2])}
        self.table_bytes = int(sum(max(a.size, 1) * (self.real_bytes if kind == "real" else INT_BYTES)
                                   for _, kind, a in self.arrays))
        # the state struct: window buffers, estimate, data window, LP tableau, 5 ints, 4 unsigned longs (LP64)
        lr, lc = self.lp_max_rows, self.lp_max_cols
        reals = (T * max(p, 1) + T * max(m, 1) + n + max(m, 1) + max(int(D), 1) + 3 * n + (lr + 1) * (lc + 1)
                 + (lr + 1) + max(lr, 1) + (lc + 1))
        self.state_bytes = int(reals * self.real_bytes + INT_BYTES * (lr + 1 + lc + 1 + 5) + 8 * 4)

    def _add(self, cname: str, arr, kind: str = "real") -> None:
        a = np.ascontiguousarray(arr).reshape(-1)
        if kind == "int":
            a = a.astype(np.int64)
            if a.size and (a.min() < -(2 ** 31) or a.max() >= 2 ** 31):
                raise ModelError("tables", f"indices that fit a 32-bit int ({cname})", f"up to {int(a.max()):,}")
        else:
            a = a.astype(float)
            b = a.astype(self.real)
            if not np.all(np.isfinite(b)):
                bad = int(np.argmax(~np.isfinite(b)))
                what = "single precision (float32)" if self.float32 else "double precision"
                raise ModelError("tables", f"finite numbers in {what}", f"{a[bad]!r} in table {cname}")
            a = b
        self.arrays.append((cname, kind, a))


def _float32_rounding(obs) -> float:
    """A priori bound on the single-precision rounding of the candidates ``x_i`` of eq. (13), in half-ranges.

    Each coordinate is a dot product ``offset + sum_c table_c z_c`` of ``d = T (p + m)`` terms over
    data within the model's output and input ranges: its rounding is at most
    ``(d + 1) 2^-24 (|offset| + sum_c |table_c| max|z_c|)`` (the rounding of the data themselves
    included).  Divided by the state's half-range and taken as a Euclidean norm over the states,
    the largest over the regions of ``I``.  ``inf`` when a range is unbounded.
    """
    from ..systems.ranges import input_range, output_range

    n, m, p, T, Kr = obs.n, obs.m, obs.p, obs.T, int(obs._K)
    yr = output_range(obs.system)
    ur = input_range(obs.system) if m else (np.zeros(0), np.zeros(0))
    if yr is None or ur is None:
        return float("inf")
    ymax = np.maximum(np.abs(yr[0]), np.abs(yr[1]))
    umax = np.maximum(np.abs(ur[0]), np.abs(ur[1]))
    zmax = np.concatenate([np.tile(ymax, T), np.tile(umax, T)])
    if not np.all(np.isfinite(zmax)):
        return float("inf")
    d = obs._table.shape[1]
    table = np.abs(obs._table[: Kr * n]).reshape(Kr, n, d)
    offset = np.abs(obs._offset[: Kr * n]).reshape(Kr, n)
    err = (d + 1) * 2.0 ** -24 * (offset + table @ zmax) / obs._sx[None, :]
    return float(np.max(np.linalg.norm(err, axis=1)))


# ---------------------------------------------------------------------------------------- C text
def _c_number(v: float, float32: bool) -> str:
    if float32:
        s = "%.9g" % float(v)
        if not any(ch in s for ch in ".en"):
            s += ".0"
        return s + "f"
    s = repr(float(v))
    return s


def _c_array(cname: str, ctype: str, a: np.ndarray, float32: bool, per_line: int = 8) -> str:
    if a.size == 0:
        return f"static const {ctype} {cname}[1] = {{0}};  /* empty */\n"
    if ctype == "int":
        items = [str(int(v)) for v in a]
    else:
        items = [_c_number(v, float32) for v in a.tolist()]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    body = ",\n    ".join(lines)
    return f"static const {ctype} {cname}[{a.size}] = {{\n    {body}\n}};\n"


#: Characters written as themselves in generated C (string literals and comments): letters,
#: digits and punctuation that neither ends a comment, starts a trigraph (``??/`` is a backslash in
#: C99) nor escapes a character.  Everything else is escaped.
_C_SAFE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789 _.,:;+-=()[]{}<>#%&|!~^@$'`")

#: Longest user text written into a comment (the rest is cut, and says so).
_COMMENT_MAX = 120


def _c_string(s: str) -> str:
    """``s`` as a C string literal: safe characters as themselves, every other byte of its UTF-8
    encoding as a three-digit octal escape (which ends after three digits, unlike ``\\x``)."""
    out = []
    for ch in s:
        if ch in _C_SAFE:
            out.append(ch)
        else:
            out.extend(f"\\{b:03o}" for b in ch.encode("utf-8"))
    return '"' + "".join(out) + '"'


def _comment(text: str) -> str:
    """User text for a ``/* ... */`` comment: safe characters as themselves, any other as
    ``<U+XXXX>`` (no ``*/``, backslash, ``?``, quote or line break can reach the compiler)."""
    text = str(text)
    cut = len(text) > _COMMENT_MAX
    body = "".join(ch if ch in _C_SAFE else f"<U+{ord(ch):04X}>" for ch in text[:_COMMENT_MAX])
    return body + ("<...>" if cut else "")


class _Writer:
    """The text of the header, the source and the driver."""

    def __init__(self, obs, data: _Tables, name: str):
        from .. import __version__
        from ..systems.fingerprint import system_fingerprint

        self.obs, self.d, self.name = obs, data, name
        self.up = name.upper()
        self.real = "float" if data.float32 else "double"
        t = data.tolerances
        f32 = data.float32
        btilde = ("pair pieces Proj_x(R_ij): a screen, then an LP per surviving piece (dense simplex)"
                  if obs.btilde_test == "pairs" else "union of polytopes over x (point-in-union, no LP)")
        s = data.sizes
        fp = system_fingerprint(obs.system)
        ops = data.ops
        self.subst = {
            "P": name, "PU": self.up, "REAL": self.real, "VERSION": __version__,
            "N": data.n, "M": data.m, "PP": data.p, "T": data.T, "MM": max(data.m, 1), "PMAX": max(data.p, 1),
            "TP": data.T * max(data.p, 1), "TM": data.T * max(data.m, 1), "D": max(data.counts["D"], 1),
            "LPR": max(data.lp_max_rows, 1), "LPR1": data.lp_max_rows + 1, "LPC1": data.lp_max_cols + 1,
            "LPT": max((data.lp_max_rows + 1) * (data.lp_max_cols + 1), 1),
            "SYSTEM": _comment(str(obs.system.name)), "FINGERPRINT": fp,
            "TABLE_BYTES": f"{data.table_bytes:,}", "STATE_BYTES": f"{data.state_bytes:,}", "MAX_OPS": f"{data.max_ops:,}",
            "OPS": "\n".join(f" *     {k:<14} {v:>14,}" for k, v in ops.items()),
            "ARITH": "float (IEEE binary32)" if f32 else "double (IEEE binary64)",
            "BTILDE": btilde, "N_PIECES": data.n_pieces, "N_REGIONS": s["n_regions"],
            "TOLS": "\n".join(f" *     {k:<16} {v!r}" for k, v in t.items() if v is not None),
            "PIVOTS": C_EXPORT_LP_PIVOTS_PER_LP,
            "F32NOTE": ("\n * Single precision: the candidates of eq. (13) round by at most "
                        f"{data.float32_rounding:.2g} of the states'\n * half-ranges; decisions within that of a "
                        "region boundary or a piece of B~_T can differ from double." if f32 else ""),
        }

    def _t(self, template: str) -> str:
        return Template(template).substitute(self.subst)

    # ------------------------------------------------------------------ header
    def header(self) -> str:
        return self._t(_HEADER)

    # ------------------------------------------------------------------ source
    def source(self) -> str:
        d, obs = self.d, self.obs
        f32 = d.float32
        ctype = {"real": "real", "int": "int"}
        tables = "".join(_c_array(cn, ctype[kind], a, f32) for cn, kind, a in d.arrays)
        t = d.tolerances
        c = d.counts
        defs = {
            "HB_N": d.n, "HB_M": d.m, "HB_P": d.p, "HB_T": d.T, "HB_PT": d.p * d.T, "HB_D": c["D"],
            "HB_K": c["K"], "HB_NX": c["K"] * d.n, "HB_NR": c["K"] * d.p * d.T, "HB_Q": c["Q"], "HB_NI": c["NI"],
            "HB_GLC": c["GLC"], "HB_NPIECES": d.n_pieces, "HB_PAIRS": 1 if obs.btilde_test == "pairs" else 0,
            "HB_LP_PIVOTS": C_EXPORT_LP_PIVOTS_PER_LP,
        }
        lines = [f"#define {k} {v}" for k, v in defs.items()]
        consts = {"OUTPUT_RTOL": t["output_rtol"], "SAME_TOL": t["same_state_tol"], "MEMBER_TOL": t["membership_tol"],
                  "INPUT_TOL": t["input_bound_tol"], "SLACK_CAP": t["slack_cap"], "PIVOT_TOL": t["lp_pivot_tol"],
                  "COST_TOL": t["lp_cost_tol"]}
        lines += [f"#define {k} ((real){_c_number(v, f32)})" for k, v in consts.items()]
        self.subst["DEFS"] = "\n".join(lines)
        self.subst["TABLES"] = tables
        self.subst["TABLE_SIZEOF"] = " + ".join(f"sizeof({cn})" for cn, _, _ in d.arrays)
        return self._t(_SOURCE)

    # ------------------------------------------------------------------ driver
    def driver(self) -> str:
        sysm = self.obs.system
        from ..sim.log import TIME_COLUMNS

        def names(seq):
            seq = list(seq)
            return "{" + ", ".join(_c_string(s) for s in seq) + "}" if seq else "{0}"

        self.subst["INPUT_NAMES"] = names(sysm.input_names)
        self.subst["OUTPUT_NAMES"] = names(sysm.output_names)
        self.subst["STATE_NAMES"] = names(sysm.state_names)
        self.subst["TIME_NAMES"] = names(TIME_COLUMNS)
        self.subst["N_TIME_NAMES"] = len(TIME_COLUMNS)
        self.subst["FMT"] = "%.9g" if self.d.float32 else "%.17g"
        return self._t(_DRIVER)


_HEADER = r"""/* ${P}.h: generated by hybobs_opt ${VERSION} (hybobs_opt.observers.c_export); do not edit.
 *
 * The lookup-table deadbeat observer of paper 002 (Gati, Ferrari-Trecate), Algorithm 4.1, for the
 * PWA system '${SYSTEM}' (fingerprint ${FINGERPRINT}),
 * horizon T = ${T}: ${N_REGIONS} regions with rank C_i = n (the set I), B~_T of eq. (15) as ${N_PIECES} pieces, tested by
 * ${BTILDE}.
 * Every step returns the estimate, the mode and the flag of LookupObserver.step() of hybobs_opt (same
 * tables, same operations in the same order); the B~_T LPs decide like the Python observer's certified LPs
 * except within rounding of the membership tolerance or at the pivot limit (${PIVOTS} (rows + columns + 2)
 * pivots), where the answer is "in B~_T" (unobservable, never a wrong state) and n_lp_limits counts it.
 *
 * Arithmetic: ${ARITH}.${F32NOTE}
 * No dynamic memory, no library beyond math.h; not reentrant across
 * threads sharing one state (each state struct is independent).
 *
 * Tables (static const, flash): ${TABLE_BYTES} bytes.  State struct (RAM): about ${STATE_BYTES} bytes.
 * Worst-case cost of one step: ${MAX_OPS} multiply-adds (a division counts as one), by part:
${OPS}
 *   (btilde_lps: every piece surviving the screen and every LP at the pivot limit; the scenarios of the
 *   papers need a small fraction of it, see ${P}_state.n_lps / n_pivots.)
 * Tolerances (hybobs_opt.tolerances):
${TOLS}
 *
 * Flags: ${PU}_OBSERVABLE 0, ${PU}_UNOBSERVABLE 1, ${PU}_FALLBACK 2, ${PU}_WARMING_UP 3 (hybobs_opt.contract).
 * Build: cc -std=c99 -O2 -c ${P}.c   (replay driver: cc -std=c99 -O2 ${P}.c ${P}_driver.c -lm -o ${P}_driver)
 */
#ifndef ${PU}_H
#define ${PU}_H

#define ${PU}_N ${N}  /* states */
#define ${PU}_M ${M}  /* inputs */
#define ${PU}_P ${PP}  /* outputs */
#define ${PU}_T ${T}  /* horizon: samples of a window */

#define ${PU}_OBSERVABLE 0
#define ${PU}_UNOBSERVABLE 1
#define ${PU}_FALLBACK 2
#define ${PU}_WARMING_UP 3

/* reason codes (texts: hybobs_opt.observers.lookup.REASONS) */
#define ${PU}_REASON_NONE 0
#define ${PU}_REASON_NONFINITE 1            /* NaN or Inf in the sample */
#define ${PU}_REASON_INPUT_OUTSIDE_U 2      /* input outside U beyond LOOKUP_INPUT_BOUND_TOL */
#define ${PU}_REASON_PREVIOUS_BAD 3         /* no prediction: the previous sample was bad */
#define ${PU}_REASON_PREDICTION_OUTSIDE 4   /* no prediction: the estimate lies in no mode's region */
#define ${PU}_NOTE_CLIPPED 6                /* prediction clipped to the state bounds */

typedef ${REAL} ${P}_real;

typedef struct {
    ${P}_real x[${N}];  /* estimate of the current state */
    int mode;           /* its mode (index of the system's modes; -1 before any) */
    int flag;           /* ${PU}_OBSERVABLE ... ${PU}_WARMING_UP */
    int reason;         /* ${PU}_REASON_* or ${PU}_NOTE_CLIPPED */
} ${P}_estimate;

typedef struct {
    ${P}_real ybuf[${TP}];   /* the window's outputs, oldest first */
    ${P}_real ubuf[${TM}];   /* the window's inputs */
    ${P}_real x[${N}];       /* current estimate */
    ${P}_real uprev[${MM}];  /* previous input (open-loop prediction) */
    ${P}_real z[${D}];       /* data window [Y; U] */
    ${P}_real xs0[${N}];     /* candidate window-start state */
    ${P}_real xnew[${N}];
    ${P}_real xs[${N}];
    ${P}_real lp_tab[${LPT}];  /* simplex tableau of the B~_T LPs */
    ${P}_real lp_rhs[${LPR1}];
    ${P}_real lp_b[${LPR}];
    ${P}_real lp_obj[${LPC1}];
    int lp_basic[${LPR1}];
    int lp_nonbasic[${LPC1}];
    int count, mode, has_previous, previous_good;
    int last_hit;               /* the piece of B~_T that held the last state found in it (-1: none) */
    unsigned long n_lps;        /* B~_T LPs solved since reset */
    unsigned long n_pivots;     /* their simplex pivots */
    unsigned long max_pivots;   /* the most pivots of one LP */
    unsigned long n_lp_limits;  /* LPs stopped at the pivot limit (or unbounded): answered "in B~_T" */
} ${P}_state;

/* Clear the window; x0 (NULL: the centre of the state box) seeds open-loop prediction. */
void ${P}_reset(${P}_state *s, const ${P}_real *x0);

/* Algorithm 4.1 for one sample u[${PU}_M], y[${PU}_P]; returns the flag, fills *e. */
int ${P}_step(${P}_state *s, const ${P}_real *u, const ${P}_real *y, ${P}_estimate *e);

/* Bytes of the static const tables, as the compiler counts them. */
unsigned long ${P}_table_bytes(void);

#endif
"""

_SOURCE = r"""/* ${P}.c: generated by hybobs_opt ${VERSION} (hybobs_opt.observers.c_export); do not edit.
 * Paper 002, Algorithm 4.1 for '${SYSTEM}', T = ${T}; see ${P}.h.  Each function mirrors the numba kernel of
 * hybobs_opt/observers/_lookup_kernels.py of the same name (same loops, same order of operations).
 */
#include <math.h>
#include "${P}.h"

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

typedef ${P}_real real;

${DEFS}

${TABLES}
unsigned long ${P}_table_bytes(void)
{
    return (unsigned long)(${TABLE_SIZEOF});
}

static real absr(real v) { return v < 0 ? -v : v; }

/* eqs. (12)-(14): index of the unique consistent candidate, or -1 (chi empty or card(chi) > 1) */
static int classify_window(const real *z, real *x_out)
{
    int k, r, c, i, found = -1;
    real acc, ymax = 1;
    for (c = 0; c < HB_PT; ++c)
        if (absr(z[c]) > ymax) ymax = absr(z[c]);
    for (k = 0; k < HB_K; ++k) {
        int ok = 1;
        for (r = HB_NX + k * HB_PT; r < HB_NX + (k + 1) * HB_PT; ++r) {  /* output residual, eq. (12) */
            acc = OFF[r];
            for (c = 0; c < HB_D; ++c) acc += TAB[r * HB_D + c] * z[c];
            if (absr(acc) > OUTPUT_RTOL * ymax) { ok = 0; break; }
        }
        if (!ok) continue;
        for (r = MSTART[k]; r < MSTART[k + 1]; ++r) {  /* [x_k; U] in P_k, eq. (14) */
            int rr = HB_NX + HB_NR + r;
            acc = OFF[rr];
            for (c = 0; c < HB_D; ++c) acc += TAB[rr * HB_D + c] * z[c];
            if (acc >= MTHR[r]) { ok = 0; break; }
        }
        if (!ok) continue;
        if (found < 0) {
            found = k;
            for (i = 0; i < HB_N; ++i) {  /* x_k = C_k^+ (Y - D_k U - f_k), eq. (13) */
                acc = OFF[k * HB_N + i];
                for (c = 0; c < HB_D; ++c) acc += TAB[(k * HB_N + i) * HB_D + c] * z[c];
                x_out[i] = acc;
            }
        } else {
            for (i = 0; i < HB_N; ++i) {
                acc = OFF[k * HB_N + i];
                for (c = 0; c < HB_D; ++c) acc += TAB[(k * HB_N + i) * HB_D + c] * z[c];
                if (absr(acc - x_out[i]) > SAME_TOL * SX[i]) return -1;
            }
        }
    }
    return found;
}

/* x_out = f_pwa(x, u), eq. (1); the mode, or -1 outside X x U */
static int pwa_step(const real *x, const real *u, real *x_out)
{
    int q, r, c, i;
    real acc;
    for (q = 0; q < HB_Q; ++q) {
        int inside = 1;
        for (r = GUARD_START[q]; r < GUARD_START[q + 1]; ++r) {
            acc = -GUARD_RHS[r];
            for (c = 0; c < HB_N; ++c) acc += GUARD[r * (HB_N + HB_M) + c] * x[c];
            for (c = 0; c < HB_M; ++c) acc += GUARD[r * (HB_N + HB_M) + HB_N + c] * u[c];
            if (acc > 0) { inside = 0; break; }
        }
        if (inside) {
            for (i = 0; i < HB_N; ++i) {
                acc = MODE_C[q * HB_N + i];
                for (c = 0; c < HB_N; ++c) acc += MODE_A[(q * HB_N + i) * HB_N + c] * x[c];
                for (c = 0; c < HB_M; ++c) acc += MODE_B[(q * HB_N + i) * HB_M + c] * u[c];
                x_out[i] = acc;
            }
            return q;
        }
    }
    for (i = 0; i < HB_N; ++i) x_out[i] = x[i];
    return -1;
}

static int clip_box(real *x)
{
    int i, moved = 0;
    for (i = 0; i < HB_N; ++i) {
        if (x[i] < XLO[i]) { x[i] = XLO[i]; moved = 1; }
        else if (x[i] > XHI[i]) { x[i] = XHI[i]; moved = 1; }
    }
    return moved;
}

/* the state at the window's last sample from its start (region k's affine map) */
static void propagate_last(int k, const real *x0, const real *z, real *x_out)
{
    int i, c;
    real acc;
    for (i = 0; i < HB_N; ++i) {
        acc = PLC[k * HB_N + i];
        for (c = 0; c < HB_N; ++c) acc += PL[(k * HB_N + i) * HB_N + c] * x0[c];
        for (c = 0; c < HB_GLC; ++c) acc += GL[(k * HB_N + i) * HB_GLC + c] * z[HB_PT + c];
        x_out[i] = acc;
    }
}

#if HB_PAIRS
/* Is max t s.t. A v + t <= b, t <= SLACK_CAP above -MEMBER_TOL?  (LookupObserver: _max_margin.)
 * Dense simplex on the tableau of the slacks: basic s_i = rhs_i - sum_j tab_ij x_j over the nonbasic
 * x_j (at zero), objective z0 + sum_j obj_j x_j.  Variables 0..cols-1 are v, cols is t - c0 (free),
 * cols + 1 + i the slack of row i (>= 0).  Free variables enter first and never leave, then Bland's
 * rule; the answer is known as soon as a feasible point has t > -tol. */
static int lp_inside(${P}_state *s, int rows, int cols, const real *A, const real *b)
{
    real *tab = s->lp_tab, *rhs = s->lp_rhs, *obj = s->lp_obj;
    int *basic = s->lp_basic, *nonbasic = s->lp_nonbasic;
    const int nc = cols + 1, nr = rows + 1, limit = HB_LP_PIVOTS * (rows + cols + 2);
    real c0 = SLACK_CAP, z0 = 0, best = 0, piv, f, inv;
    int i, j, it, je, ir, id, dir;
    for (i = 0; i < rows; ++i)
        if (b[i] < c0) c0 = b[i];
    if (c0 > -MEMBER_TOL) return 1;  /* v = 0 */
    for (i = 0; i < rows; ++i) {
        for (j = 0; j < cols; ++j) tab[i * nc + j] = A[i * cols + j];
        tab[i * nc + cols] = 1;
        rhs[i] = b[i] - c0;
        basic[i] = nc + i;
    }
    for (j = 0; j < cols; ++j) tab[rows * nc + j] = 0;
    tab[rows * nc + cols] = 1;
    rhs[rows] = SLACK_CAP - c0;
    basic[rows] = nc + rows;
    for (j = 0; j < nc; ++j) { obj[j] = 0; nonbasic[j] = j; }
    obj[cols] = 1;
    s->n_lps++;
    for (it = 0; it < limit; ++it) {
        if (c0 + z0 > -MEMBER_TOL) break;  /* a feasible point with t > -tol */
        je = -1;
        id = 0;
        for (j = 0; j < nc; ++j)  /* a free nonbasic variable that moves the objective */
            if (nonbasic[j] < nc && (obj[j] > COST_TOL || obj[j] < -COST_TOL) && (je < 0 || nonbasic[j] < id)) {
                je = j;
                id = nonbasic[j];
            }
        if (je < 0)
            for (j = 0; j < nc; ++j)  /* Bland: the lowest slack with a positive reduced cost */
                if (nonbasic[j] >= nc && obj[j] > COST_TOL && (je < 0 || nonbasic[j] < id)) {
                    je = j;
                    id = nonbasic[j];
                }
        if (je < 0) {  /* optimal: t* = c0 + z0 <= -tol */
            if ((unsigned long)it > s->max_pivots) s->max_pivots = (unsigned long)it;
            return 0;
        }
        dir = obj[je] > 0 ? 1 : -1;
        ir = -1;
        for (i = 0; i < nr; ++i) {  /* ratio test over the slacks (free basic variables are unbounded) */
            if (basic[i] < nc) continue;
            piv = dir > 0 ? tab[i * nc + je] : -tab[i * nc + je];
            if (piv > PIVOT_TOL) {
                f = rhs[i] > 0 ? rhs[i] / piv : 0;
                if (ir < 0 || f < best || (f == best && basic[i] < basic[ir])) { ir = i; best = f; }
            }
        }
        if (ir < 0) break;  /* unbounded: impossible with t <= SLACK_CAP up to rounding; answer "inside" */
        inv = 1 / tab[ir * nc + je];
        for (j = 0; j < nc; ++j)
            if (j != je) tab[ir * nc + j] *= inv;
        rhs[ir] *= inv;
        tab[ir * nc + je] = inv;
        for (i = 0; i < nr; ++i) {
            if (i == ir) continue;
            f = tab[i * nc + je];
            if (f == 0) continue;
            for (j = 0; j < nc; ++j)
                if (j != je) tab[i * nc + j] -= f * tab[ir * nc + j];
            rhs[i] -= f * rhs[ir];
            tab[i * nc + je] = -f * inv;
        }
        f = obj[je];
        for (j = 0; j < nc; ++j)
            if (j != je) obj[j] -= f * tab[ir * nc + j];
        z0 += f * rhs[ir];
        obj[je] = -f * inv;
        i = basic[ir];
        basic[ir] = nonbasic[je];
        nonbasic[je] = i;
        s->n_pivots++;
    }
    if ((unsigned long)it > s->max_pivots) s->max_pivots = (unsigned long)it;
    if (!(c0 + z0 > -MEMBER_TOL)) s->n_lp_limits++;
    return 1;
}

/* is the window-start state x (xs: scaled by SX around XC) in the piece Proj_x(R_ij) number q? */
static int piece_inside(${P}_state *s, int q, const real *x)
{
    int r, c, i, rows, o;
    real acc;
    for (r = EX_START[q]; r < EX_START[q + 1]; ++r) {  /* pair_screen */
        acc = -EX_B[r];
        for (c = 0; c < HB_N; ++c) acc += EX_A[r * HB_N + c] * s->xs[c];
        if (acc > MEMBER_TOL) return 0;
    }
    rows = LP_ROWS[q];
    if (rows == 0) return 1;
    o = LP_ROFF[q];
    for (i = 0; i < HB_N; ++i) s->xnew[i] = (x[i] - XC[i]) / PSX[i];
    for (r = 0; r < rows; ++r) {
        acc = LP_B0[o + r];
        for (c = 0; c < HB_N; ++c) acc += LP_B1[(o + r) * HB_N + c] * s->xnew[c];
        s->lp_b[r] = acc;
    }
    return lp_inside(s, rows, LP_COLS[q], LP_A + LP_AOFF[q], s->lp_b);
}

/* eq. (15): is the window-start state x in one of the pieces of B~_T?  The piece that held the
 * last state found in B~_T is tried first (as LookupObserver does): the answer is the same. */
static int in_btilde(${P}_state *s, const real *x)
{
    int q, i;
    for (i = 0; i < HB_N; ++i) s->xs[i] = (x[i] - XC[i]) / SX[i];
    if (s->last_hit >= 0 && piece_inside(s, s->last_hit, x)) return 1;
    for (q = 0; q < HB_NPIECES; ++q)
        if (q != s->last_hit && piece_inside(s, q, x)) {
            s->last_hit = q;
            return 1;
        }
    return 0;
}
#else
/* eq. (15): is x in one of the polytopes of B~_T? (in_union) */
static int in_btilde(${P}_state *s, const real *x)
{
    int q, r, c;
    real acc;
    (void)s;
    for (q = 0; q < HB_NPIECES; ++q) {
        int inside = 1;
        for (r = BT_START[q]; r < BT_START[q + 1]; ++r) {
            acc = -BT_B[r];
            for (c = 0; c < HB_N; ++c) acc += BT_A[r * HB_N + c] * x[c];
            if (acc > MEMBER_TOL) { inside = 0; break; }
        }
        if (inside) return 1;
    }
    return 0;
}
#endif

void ${P}_reset(${P}_state *s, const real *x0)
{
    int i;
    for (i = 0; i < HB_N; ++i) s->x[i] = x0 ? x0[i] : XDEF[i];
    for (i = 0; i < ${TP}; ++i) s->ybuf[i] = 0;
    for (i = 0; i < ${TM}; ++i) s->ubuf[i] = 0;
    for (i = 0; i < ${MM}; ++i) s->uprev[i] = 0;
    s->count = 0;
    s->mode = -1;
    s->has_previous = 0;
    s->previous_good = 0;
    s->last_hit = -1;
    s->n_lps = s->n_pivots = s->max_pivots = s->n_lp_limits = 0;
}

static int finish(const ${P}_state *s, ${P}_estimate *e, int flag, int reason)
{
    int i;
    for (i = 0; i < HB_N; ++i) e->x[i] = s->x[i];
    e->mode = s->mode;
    e->flag = flag;
    e->reason = reason;
    return flag;
}

int ${P}_step(${P}_state *s, const real *u, const real *y, ${P}_estimate *e)
{
    int good = 1, reason = ${PU}_REASON_NONE, pred_ok = 1, pred_reason = ${PU}_REASON_NONE, i, j, c, r, k;
    real acc;
    for (c = 0; c < HB_M; ++c)
        if (!isfinite(u[c])) good = 0;
    for (c = 0; c < HB_P; ++c)
        if (!isfinite(y[c])) good = 0;
    if (!good) reason = ${PU}_REASON_NONFINITE;
    if (good) {
        for (r = 0; r < HB_NI; ++r) {  /* u in U (rows unit in scaled input coordinates) */
            acc = -IN_B[r];
            for (c = 0; c < HB_M; ++c) acc += IN_A[r * HB_M + c] * u[c];
            if (acc > INPUT_TOL) { good = 0; reason = ${PU}_REASON_INPUT_OUTSIDE_U; break; }
        }
    }
    /* step 2.1: open-loop prediction x(t) = f_pwa(x(t-1), u(t-1)), used unless reconstructed */
    if (s->has_previous) {
        if (s->previous_good) {
            int clipped = clip_box(s->x);
            int q = pwa_step(s->x, s->uprev, s->xnew);
            if (q >= 0) {
                s->mode = q;
                for (i = 0; i < HB_N; ++i) s->x[i] = s->xnew[i];
                if (clip_box(s->x)) clipped = 1;
                if (clipped) pred_reason = ${PU}_NOTE_CLIPPED;
            } else {
                pred_ok = 0;
                pred_reason = ${PU}_REASON_PREDICTION_OUTSIDE;
            }
        } else {
            pred_ok = 0;
            pred_reason = ${PU}_REASON_PREVIOUS_BAD;
        }
    }
    s->has_previous = 1;
    s->previous_good = good;
    for (c = 0; c < HB_M; ++c) s->uprev[c] = good ? u[c] : (real)NAN;
    if (!good) {
        s->count = 0;  /* a bad sample breaks the window */
        return finish(s, e, ${PU}_FALLBACK, reason);
    }
    for (j = 0; j < HB_T - 1; ++j) {
        for (c = 0; c < HB_P; ++c) s->ybuf[j * HB_P + c] = s->ybuf[(j + 1) * HB_P + c];
        for (c = 0; c < HB_M; ++c) s->ubuf[j * HB_M + c] = s->ubuf[(j + 1) * HB_M + c];
    }
    for (c = 0; c < HB_P; ++c) s->ybuf[(HB_T - 1) * HB_P + c] = y[c];
    for (c = 0; c < HB_M; ++c) s->ubuf[(HB_T - 1) * HB_M + c] = u[c];
    if (s->count < HB_T) s->count++;
    if (s->count < HB_T) return finish(s, e, ${PU}_WARMING_UP, pred_reason);
    for (j = 0; j < HB_T; ++j) {
        for (c = 0; c < HB_P; ++c) s->z[j * HB_P + c] = s->ybuf[j * HB_P + c];
        for (c = 0; c < HB_M; ++c) s->z[HB_PT + j * HB_M + c] = s->ubuf[j * HB_M + c];
    }
    k = classify_window(s->z, s->xs0);
    if (k >= 0 && !in_btilde(s, s->xs0)) {
        propagate_last(k, s->xs0, s->z, s->x);
        s->mode = LASTMODE[k];
        return finish(s, e, ${PU}_OBSERVABLE, ${PU}_REASON_NONE);
    }
    return finish(s, e, pred_ok ? ${PU}_UNOBSERVABLE : ${PU}_FALLBACK, pred_reason);
}
"""

_DRIVER = r"""/* ${P}_driver.c: generated by hybobs_opt ${VERSION}; replays a CSV log through ${P}_step.
 *
 *   ${P}_driver LOG.csv OUT.csv [TIMES.csv [REPEATS]]
 *   ${P}_driver --sizes
 *
 * LOG.csv: a header naming the system's inputs and outputs (any order; other columns are ignored, a
 * time column t or time is copied); a cell that is not a number is read as NaN.  OUT.csv: [t,] the
 * states, mode, flag (observable, unobservable, fallback, warming_up) and reason code per sample, as
 * hybobs observe --out writes them (plus the reason).  With TIMES.csv the log is replayed REPEATS
 * times (default 1, each from a reset) and the nanoseconds of every step call (clock_gettime,
 * CLOCK_MONOTONIC) are written, one line per sample, one column per repeat.  The last line on
 * stdout counts the B~_T LPs of the first replay.  Exit status 2 on bad input.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "${P}.h"

#define LINE_MAX_CHARS 65536

static const char *const INPUT_NAMES[] = ${INPUT_NAMES};
static const char *const OUTPUT_NAMES[] = ${OUTPUT_NAMES};
static const char *const STATE_NAMES[] = ${STATE_NAMES};
static const char *const TIME_NAMES[] = ${TIME_NAMES};
static const char *const FLAG_NAMES[] = {"observable", "unobservable", "fallback", "warming_up"};

static int fail(const char *what, const char *detail)
{
    fprintf(stderr, "${P}_driver: error: %s%s\n", what, detail ? detail : "");
    return 2;
}

static char *trim(char *s)
{
    char *end;
    while (*s == ' ' || *s == '\t' || *s == '"') ++s;
    end = s + strlen(s);
    while (end > s && (end[-1] == ' ' || end[-1] == '\t' || end[-1] == '\r' || end[-1] == '\n' || end[-1] == '"')) *--end = 0;
    return s;
}

/* split line in place at commas; returns the number of cells (at most max) */
static int split(char *line, char **cells, int max)
{
    int n = 0;
    char *p = line;
    while (n < max) {
        char *comma = strchr(p, ',');
        if (comma) *comma = 0;
        cells[n++] = trim(p);
        if (!comma) break;
        p = comma + 1;
    }
    return n;
}

static double number(const char *cell)
{
    char *end;
    double v;
    if (!*cell) return NAN;
    v = strtod(cell, &end);
    return (*end == 0 && end != cell) ? v : NAN;
}

static long nanoseconds(const struct timespec *a, const struct timespec *b)
{
    return (long)(b->tv_sec - a->tv_sec) * 1000000000L + (long)(b->tv_nsec - a->tv_nsec);
}

int main(int argc, char **argv)
{
    static char line[LINE_MAX_CHARS];
    static char *cells[4096];
    int col_u[${MM}], col_y[${PMAX}], col_t = -1, ncols, i, j, c, rep, repeats = 1;
    size_t n = 0, cap = 1024, k;
    double *t = NULL;
    ${P}_real *U = NULL, *Y = NULL, *X = NULL;
    int *mode = NULL, *flag = NULL, *reason = NULL;
    long *ns = NULL;
    FILE *in, *out;
    ${P}_state s;
    ${P}_estimate e;
    struct timespec t0, t1;

    if (argc == 2 && strcmp(argv[1], "--sizes") == 0) {
        printf("table_bytes %lu\nstate_bytes %lu\n", ${P}_table_bytes(), (unsigned long)sizeof(${P}_state));
        return 0;
    }
    if (argc < 3 || argc > 5) return fail("usage: ${P}_driver LOG.csv OUT.csv [TIMES.csv [REPEATS]] | --sizes", NULL);
    if (argc == 5) {
        repeats = atoi(argv[4]);
        if (repeats < 1) return fail("REPEATS: expected a positive integer, got ", argv[4]);
    }
    in = fopen(argv[1], "r");
    if (!in) return fail("cannot read ", argv[1]);
    if (!fgets(line, sizeof line, in)) return fail("empty log ", argv[1]);
    ncols = split(line, cells, 4096);
    for (i = 0; i < ${M}; ++i) {
        col_u[i] = -1;
        for (c = 0; c < ncols; ++c) if (strcmp(cells[c], INPUT_NAMES[i]) == 0) col_u[i] = c;
        if (col_u[i] < 0) return fail("missing input column ", INPUT_NAMES[i]);
    }
    for (i = 0; i < ${PP}; ++i) {
        col_y[i] = -1;
        for (c = 0; c < ncols; ++c) if (strcmp(cells[c], OUTPUT_NAMES[i]) == 0) col_y[i] = c;
        if (col_y[i] < 0) return fail("missing output column ", OUTPUT_NAMES[i]);
    }
    for (c = 0; c < ncols && col_t < 0; ++c)
        for (i = 0; i < ${N_TIME_NAMES}; ++i) if (strcmp(cells[c], TIME_NAMES[i]) == 0) col_t = c;
    t = malloc(cap * sizeof *t);
    U = malloc(cap * ${MM} * sizeof *U);
    Y = malloc(cap * ${PMAX} * sizeof *Y);
    if (!t || !U || !Y) return fail("out of memory", NULL);
    while (fgets(line, sizeof line, in)) {
        if (!strchr(line, '\n') && !feof(in)) return fail("line too long in ", argv[1]);
        if (trim(line)[0] == 0) continue;
        if (n == cap) {
            cap *= 2;
            t = realloc(t, cap * sizeof *t);
            U = realloc(U, cap * ${MM} * sizeof *U);
            Y = realloc(Y, cap * ${PMAX} * sizeof *Y);
            if (!t || !U || !Y) return fail("out of memory", NULL);
        }
        ncols = split(line, cells, 4096);
        for (i = 0; i < ${M}; ++i) U[n * ${MM} + i] = (${P}_real)(col_u[i] < ncols ? number(cells[col_u[i]]) : NAN);
        for (i = 0; i < ${PP}; ++i) Y[n * ${PMAX} + i] = (${P}_real)(col_y[i] < ncols ? number(cells[col_y[i]]) : NAN);
        t[n] = col_t >= 0 && col_t < ncols ? number(cells[col_t]) : NAN;
        ++n;
    }
    fclose(in);
    X = malloc((n ? n : 1) * ${N} * sizeof *X);
    mode = malloc((n ? n : 1) * sizeof *mode);
    flag = malloc((n ? n : 1) * sizeof *flag);
    reason = malloc((n ? n : 1) * sizeof *reason);
    ns = malloc((n ? n : 1) * (size_t)repeats * sizeof *ns);
    if (!X || !mode || !flag || !reason || !ns) return fail("out of memory", NULL);
    {
        unsigned long n_lps = 0, n_pivots = 0, max_pivots = 0, n_lp_limits = 0;
        for (rep = 0; rep < repeats; ++rep) {
            ${P}_reset(&s, NULL);
            for (k = 0; k < n; ++k) {
                clock_gettime(CLOCK_MONOTONIC, &t0);
                ${P}_step(&s, U + k * ${MM}, Y + k * ${PMAX}, &e);
                clock_gettime(CLOCK_MONOTONIC, &t1);
                ns[k * (size_t)repeats + rep] = nanoseconds(&t0, &t1);
                if (rep == 0) {
                    for (j = 0; j < ${N}; ++j) X[k * ${N} + j] = e.x[j];
                    mode[k] = e.mode;
                    flag[k] = e.flag;
                    reason[k] = e.reason;
                }
            }
            if (rep == 0) {
                n_lps = s.n_lps;
                n_pivots = s.n_pivots;
                max_pivots = s.max_pivots;
                n_lp_limits = s.n_lp_limits;
            }
        }
        out = fopen(argv[2], "w");
        if (!out) return fail("cannot write ", argv[2]);
        if (col_t >= 0) fprintf(out, "%s,", TIME_NAMES[0]);
        for (j = 0; j < ${N}; ++j) fprintf(out, "%s,", STATE_NAMES[j]);
        fprintf(out, "mode,flag,reason\n");
        for (k = 0; k < n; ++k) {
            if (col_t >= 0) fprintf(out, "%.17g,", t[k]);
            for (j = 0; j < ${N}; ++j) fprintf(out, "${FMT},", (double)X[k * ${N} + j]);
            fprintf(out, "%d,%s,%d\n", mode[k], FLAG_NAMES[flag[k]], reason[k]);
        }
        if (fclose(out) != 0) return fail("cannot write ", argv[2]);
        if (argc >= 4) {
            long overhead = -1;
            out = fopen(argv[3], "w");
            if (!out) return fail("cannot write ", argv[3]);
            for (k = 0; k < n; ++k)
                for (rep = 0; rep < repeats; ++rep)
                    fprintf(out, rep + 1 < repeats ? "%ld," : "%ld\n", ns[k * (size_t)repeats + rep]);
            if (fclose(out) != 0) return fail("cannot write ", argv[3]);
            for (k = 0; k < 1000; ++k) {  /* the cost of the two clock_gettime calls alone */
                long d;
                clock_gettime(CLOCK_MONOTONIC, &t0);
                clock_gettime(CLOCK_MONOTONIC, &t1);
                d = nanoseconds(&t0, &t1);
                if (overhead < 0 || d < overhead) overhead = d;
            }
            printf("clock_overhead_ns %ld\n", overhead);
        }
        printf("steps %lu lps %lu pivots %lu max_pivots %lu lp_limits %lu\n", (unsigned long)n, n_lps, n_pivots,
               max_pivots, n_lp_limits);
    }
    free(t); free(U); free(Y); free(X); free(mode); free(flag); free(reason); free(ns);
    return 0;
}
"""
