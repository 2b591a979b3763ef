"""Polytope operations of ``hybobs_opt.geometry`` against the field's libraries (issues 19, 39).

Run ``python -m benchmarks.bench_polytope`` (full, a few minutes) or ``--quick`` (smoke test).
Writes ``benchmarks/results/polytope.json`` (quick runs go to ``benchmarks/results/quick/``).

Five operations on random polytopes in 2-6 dimensions, every implementation on the same instances
in the same run, repeats interleaved (one call of each in turn) so that the load of a shared
machine falls on all alike:

Every pycddlib call is handed nested lists (``ndarray.tolist()``), which pycddlib reads 4-6 x
faster than numpy arrays, so its times are its best.

* ``vertices`` (H -> V): ``Polytope.vertices()``; pycddlib (``copy_generators``, unchecked);
  the ``polytope`` package (``extreme``); scipy (a Chebyshev centre by ``linprog``, then
  ``HalfspaceIntersection``).
* ``redundancy``: ``Polytope.remove_redundant()``; pycddlib (``redundant_rows``);
  ``polytope.reduce``; scipy (Chebyshev centre, ``HalfspaceIntersection.dual_vertices``).
* ``v_to_h``: ``Polytope.from_vertices`` on random points; pycddlib (``copy_inequalities``);
  ``polytope.qhull``; scipy (``ConvexHull``, its triangulated facets merged).
* ``volume``: ``Polytope.volume("exact")``; pycddlib's vertices + qhull's volume; the
  ``polytope`` package (``volume``: Monte Carlo with its default sample size, so never exact);
  scipy (HalfspaceIntersection, then ``ConvexHull(...).volume``).
* ``v_to_h_degenerate`` (issue 39): ``from_vertices`` on degenerate point sets with known facets
  (the rotated cube's vertices with duplicates, interior points and points on facets; with points
  1e-9 inside facets and on ridges; the vertices of a random polytope, whose facets are not
  simplices), the same peers as ``v_to_h`` (the polytope package up to 4-D: minutes above).
* ``chebyshev`` (issue 39): ``Polytope.chebyshev_ball()`` against the same LP posed to
  ``scipy.optimize.linprog`` (HiGHS, unchecked; target: within 1.5 x) and ``polytope.cheby_ball``.
* ``projection_2d``: ``Polytope.project([0, 1])`` (``auto``: checked vertices and their checked
  2-D hull up to 6-D) and ``method="hull"`` (the LP iterative hull ``auto`` used before issue 39);
  pycddlib (``block_elimination`` of the other coordinates, unchecked); ``polytope.projection``;
  the limit (target: within 3 x): cddlib's vertices (``limit_cdd``) or qhull's halfspace
  intersection on a ``linprog`` centre (``limit_qhull``), projected, ``ConvexHull`` in 2-D.
* ``volume`` at 6-D also runs the instance whose exact volume raised ``SolverError`` when issue 39
  was filed.

Also ``hybobs_lp_path``: the hand-written path the library path replaced (every library answer
disabled), where it finishes in reasonable time.

Every answer is compared with an oracle: brute-force vertices (every d-subset of rows solved with
numpy, the feasible ones kept), LPs for the facets (``linprog`` per row), ``ConvexHull`` of the
oracle vertices for volumes and 2-D projections.  An implementation is *correct* on an instance
when it agrees (vertex sets and row sets within 1e-6 of the instance's size, volumes to 1e-9
relative); ``ratio`` is hybobs_opt's median time over the fastest correct peer's, per instance,
and its median over the instances of a dimension is the figure reported.  Target (issue 19):
within 3 x of the fastest correct peer.  The library counters of ``hybobs_opt.geometry.vertices``
record how often a library answer was accepted and how often a check sent it to another path.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from ._machine import git_state, json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"

#: Target of issue 19: hybobs_opt within this factor of the fastest correct peer.
TARGET_RATIO = 3.0
DIMS = (2, 3, 4, 5, 6)
#: Agreement tolerance, relative to the size of the instance.
AGREE_RTOL = 1e-6
#: A slow implementation is called once per instance when its first call takes longer than this.
SLOW_SECONDS = 0.5
#: A peer whose warm-up call takes longer than this is not run in the higher dimensions of that
#: operation (recorded as skipped): the polytope package's V -> H took 7 s at d = 5.
SKIP_SECONDS = 20.0
#: Implementations timed in a block of their own after the others, per operation: the ``polytope``
#: package's volume is Monte Carlo (it never agrees with the exact volume, so it is never the
#: fastest correct peer) and sweeps arrays of a few MB; interleaved, it slowed every call after
#: it on this machine (d = 4: scipy 2.4 -> 7.2 ms, hybobs 1.5 -> 3.5 ms, pycddlib+qhull 1.0 ->
#: 1.2-2.8 ms per call, medians of 9), which made the d = 4 ratio 4.1 instead of 1.4.
#: The same for the polytope package and the hand-written paths in every operation (issue 39): each
#: slowed the call after it (V -> H at d = 2, scipy's ConvexHull right after the polytope package:
#: 15.7 ms instead of 0.16 ms per call, medians of 9 on a loaded machine).
TIMED_APART = {op: ("polytope", "hybobs_lp_path", "hybobs_lp_hull")
               for op in ("vertices", "redundancy", "v_to_h", "v_to_h_degenerate", "volume", "chebyshev", "projection_2d")}


#: Targets other than TARGET_RATIO x the fastest correct peer (issue 39): the Chebyshev ball within
#: 1.5 x a bare ``linprog`` (HiGHS) on the same LP; projection to 2-D within 3 x the limit (cddlib's
#: or qhull's vertices, projected, and a 2-D hull).
OP_TARGETS = {"chebyshev": ("linprog", 1.5), "projection_2d": ("limit", 3.0)}
#: Peers not run above a dimension: the polytope package's V -> H of a few hundred points in 5-6 D
#: takes minutes.
PEER_MAX_DIM = {("v_to_h_degenerate", "polytope"): 4}
#: Degenerate point sets for V -> H (one instance of each per dimension), with exact facets.
DEGENERATE_KINDS = ("cube_duplicates", "cube_near_facets", "polytope_vertices")


def log(msg: str) -> None:
    print(f"[bench_polytope] {msg}", file=sys.stderr, flush=True)


def _load() -> list[float]:
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return []


# ---------------------------------------------------------------------- instances and oracles
def random_polytope(rng, d: int) -> tuple[np.ndarray, np.ndarray]:
    """``3 d`` random unit rows with offsets in [0.5, 1.5], the box ``[-2, 2]^d`` and ``d`` loose rows.

    The box rows are mostly redundant and the loose rows (offset 3) always are, so redundancy
    removal has work to do; 6 d rows in all (12 at d = 2, 36 at d = 6).
    """
    A = rng.normal(size=(3 * d, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.uniform(0.5, 1.5, 3 * d)
    L = rng.normal(size=(d, d))
    L /= np.linalg.norm(L, axis=1)[:, None]
    return (np.vstack([A, np.eye(d), -np.eye(d), L]),
            np.concatenate([b, 2.0 * np.ones(2 * d), 3.0 * np.ones(d)]))


def brute_force_vertices(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Every d-subset of rows solved with numpy; the solutions satisfying all rows, deduplicated."""
    m, d = A.shape
    out = []
    subsets = itertools.combinations(range(m), d)
    while True:
        chunk = np.array(list(itertools.islice(subsets, 50_000)))
        if chunk.size == 0:
            break
        M = A[chunk]
        ok = np.abs(np.linalg.det(M)) > 1e-12
        X = np.linalg.solve(M[ok], b[chunk[ok]][..., None])[..., 0]
        out.append(X[np.all(X @ A.T <= b + 1e-9 * (1 + np.abs(b)), axis=1)])
    X = np.vstack(out)
    keep = []
    for x in X:
        if not keep or np.min(np.max(np.abs(np.array(keep) - x), axis=1)) > 1e-7:
            keep.append(x)
    return np.array(keep)


def degenerate_points(rng, d: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """A degenerate point set in ``d`` dimensions and its facets (unit rows ``(a, b)``), known exactly.

    ``cube_duplicates``: the vertices of ``[-1, 1]^d`` (rotated), five of them twice, three
    interior points and ``2 d`` points on facets; ``cube_near_facets``: the vertices, ``2 d`` points
    1e-9 inside facets and ``2 d`` on ridges (two coordinates at +-1); ``polytope_vertices``: the
    vertices of a random polytope (:func:`random_polytope`, non-simplicial facets), its facets by LP.
    """
    if kind == "polytope_vertices":
        A, b = random_polytope(rng, d)
        k = lp_facets(A, b)
        return brute_force_vertices(A, b), unit_rows(A[k], b[k])
    Q, _ = np.linalg.qr(rng.normal(size=(d, d)))
    C = np.array(list(itertools.product([-1.0, 1.0], repeat=d)))
    F = rng.uniform(-1.0, 1.0, (2 * d, d))
    axes = rng.integers(0, d, 2 * d)
    signs = rng.choice([-1.0, 1.0], 2 * d)
    if kind == "cube_duplicates":
        F[np.arange(2 * d), axes] = signs
        Y = np.vstack([C, C[:5], 0.5 * C[:3], F])
    else:
        F[np.arange(2 * d), axes] = signs * (1.0 - 1e-9)
        R = rng.uniform(-1.0, 1.0, (2 * d, d))
        R[np.arange(2 * d), axes] = signs
        R[np.arange(2 * d), (axes + 1) % d] = -signs
        Y = np.vstack([C, F, R])
    rows = np.vstack([Q.T, -Q.T])  # y_i = (Q' x)_i <= 1 and -y_i <= 1
    return Y @ Q.T, unit_rows(rows, np.ones(2 * d))


def chebyshev_oracle(A: np.ndarray, b: np.ndarray) -> tuple:
    """``((A, b), radius)``: the Chebyshev radius by HiGHS's interior-point method (not the simplex
    the ``linprog`` peer uses)."""
    from scipy.optimize import linprog

    d = A.shape[1]
    c = np.zeros(d + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=np.hstack([A, np.linalg.norm(A, axis=1)[:, None]]), b_ub=b,
                  bounds=[(None, None)] * (d + 1), method="highs-ipm")
    return (A, b), float(res.x[-1])


def lp_facets(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rows that are facets, by ``linprog``: max of the row over the others exceeds its bound."""
    from scipy.optimize import linprog

    keep = np.zeros(A.shape[0], dtype=bool)
    for i in range(A.shape[0]):
        others = np.delete(np.arange(A.shape[0]), i)
        res = linprog(-A[i], A_ub=np.vstack([A[others], A[i]]), b_ub=np.append(b[others], b[i] + 1.0),
                      bounds=(None, None), method="highs")
        keep[i] = -res.fun > b[i] + 1e-7
    return keep


def same_points(V, W, size: float) -> bool:
    V, W = np.asarray(V, float), np.asarray(W, float)
    if V.ndim != 2 or V.shape != W.shape:
        return False
    tol = AGREE_RTOL * size
    return all(np.min(np.max(np.abs(V - w), axis=1)) <= tol for w in W) and \
        all(np.min(np.max(np.abs(W - v), axis=1)) <= tol for v in V)


def unit_rows(A, b) -> np.ndarray:
    A, b = np.asarray(A, float), np.asarray(b, float).ravel()
    n = np.linalg.norm(A, axis=1)
    return np.hstack([A / n[:, None], (b / n)[:, None]])


def same_rows(R, S, size: float) -> bool:
    """Equal sets of unit rows ``(a, b)`` (duplicates ignored)."""
    R, S = np.asarray(R, float), np.asarray(S, float)
    if R.size == 0 or S.size == 0:
        return R.size == S.size
    tol = AGREE_RTOL * max(size, 1.0)
    return all(np.min(np.max(np.abs(S - r), axis=1)) <= tol for r in R) and \
        all(np.min(np.max(np.abs(R - s), axis=1)) <= tol for s in S)


def polygon_vertices(A, b) -> np.ndarray:
    """Vertices of a bounded 2-D ``{A x <= b}``: qhull's halfspace intersection, deduplicated.

    (Brute force over pairs of rows is quadratic in the rows, and cddlib's block elimination
    returns thousands of redundant rows from 6-D.)
    """
    A, b = np.asarray(A, float), np.asarray(b, float).ravel()
    n = np.linalg.norm(A, axis=1)
    A, b = A[n > 0] / n[n > 0, None], b[n > 0] / n[n > 0]
    X = scipy_halfspaces(A, b).intersections
    keep = []
    for x in X:
        if not keep or np.min(np.max(np.abs(np.array(keep) - x), axis=1)) > 1e-9:
            keep.append(x)
    return np.array(keep)


# ---------------------------------------------------------------------- the implementations
@contextlib.contextmanager
def library_paths_disabled():
    """The hand-written path of hybobs_opt: every library answer made to fail (and counted)."""
    import hybobs_opt.geometry.polytope as pmod
    from hybobs_opt.geometry import vertices as vmod

    saved = dict(vmod._LIBRARIES)
    saved_hull = pmod.hull_rows
    counts = vmod.COUNTERS.snapshot()  # the disabled answers are not the library path's fall-backs
    for k in saved:
        vmod._LIBRARIES[k] = lambda A, b: "disabled by the benchmark"
    pmod.hull_rows = lambda X, op="hull": None
    try:
        yield
    finally:
        vmod._LIBRARIES.update(saved)
        pmod.hull_rows = saved_hull
        vmod.COUNTERS.reset()
        vmod.COUNTERS.accepted.update(counts["accepted"])
        vmod.COUNTERS.fallbacks.update(counts["fallbacks"])
        vmod.COUNTERS.reasons.extend(counts["reasons"])


def scipy_centre(A, b):
    from scipy.optimize import linprog

    d = A.shape[1]
    c = np.zeros(d + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=np.hstack([A, np.linalg.norm(A, axis=1)[:, None]]), b_ub=b,
                  bounds=[(None, None)] * d + [(0, None)], method="highs")
    return res.x[:d]


def scipy_halfspaces(A, b):
    from scipy.spatial import HalfspaceIntersection

    return HalfspaceIntersection(np.hstack([A, -b[:, None]]), scipy_centre(A, b))


def cdd_vertices(A, b):
    import cdd

    mat = cdd.matrix_from_array(np.hstack([b[:, None], -A]).tolist(), rep_type=cdd.RepType.INEQUALITY)
    G = np.array(cdd.copy_generators(cdd.polyhedron_from_matrix(mat)).array)
    return G[:, 1:]


def implementations(op: str, have_cdd: bool, have_pc: bool):
    """``{name: callable(instance) -> answer}`` for one operation."""
    from scipy.spatial import ConvexHull

    from hybobs_opt.geometry.polytope import Polytope

    out = {}
    if op == "vertices":
        out["hybobs"] = lambda A, b: Polytope(A, b).vertices()
        out["hybobs_lp_path"] = lambda A, b: _lp_path(lambda: Polytope(A, b).vertices())
        if have_cdd:
            out["pycddlib"] = cdd_vertices
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda A, b: pc.extreme(pc.Polytope(A, b))
        out["scipy"] = lambda A, b: scipy_halfspaces(A, b).intersections
    elif op == "redundancy":
        out["hybobs"] = lambda A, b: (lambda R: unit_rows(R.A, R.b))(Polytope(A, b).remove_redundant())
        out["hybobs_lp_path"] = lambda A, b: _lp_path(lambda: (lambda R: unit_rows(R.A, R.b))(Polytope(A, b).remove_redundant()))
        if have_cdd:
            import cdd

            def cdd_red(A, b):
                red = cdd.redundant_rows(cdd.matrix_from_array(np.hstack([b[:, None], -A]).tolist(), rep_type=cdd.RepType.INEQUALITY))
                keep = np.array([i for i in range(A.shape[0]) if i not in red])
                return unit_rows(A[keep], b[keep])

            out["pycddlib"] = cdd_red
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda A, b: (lambda R: unit_rows(R.A, R.b))(pc.reduce(pc.Polytope(A, b)))
        out["scipy"] = lambda A, b: (lambda k: unit_rows(A[k], b[k]))(np.unique(scipy_halfspaces(A, b).dual_vertices))
    elif op == "chebyshev":
        out["hybobs"] = lambda A, b: Polytope(A, b).chebyshev_ball()

        def bare_linprog(A, b):
            from scipy.optimize import linprog

            d = A.shape[1]
            c = np.zeros(d + 1)
            c[-1] = -1.0
            res = linprog(c, A_ub=np.hstack([A, np.linalg.norm(A, axis=1)[:, None]]), b_ub=b,
                          bounds=[(None, None)] * (d + 1), method="highs")
            return res.x[:d], float(res.x[-1])

        out["linprog"] = bare_linprog
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda A, b: (lambda rc: (np.asarray(rc[1], float).ravel(), float(rc[0])))(pc.cheby_ball(pc.Polytope(A, b)))
    elif op in ("v_to_h", "v_to_h_degenerate"):
        out["hybobs"] = lambda X: (lambda H: unit_rows(H.A, H.b))(Polytope.from_vertices(X))
        out["hybobs_lp_path"] = lambda X: _lp_path(lambda: (lambda H: unit_rows(H.A, H.b))(Polytope.from_vertices(X)))
        if have_cdd:
            import cdd

            def cdd_vh(X):
                mat = cdd.matrix_from_array(np.hstack([np.ones((X.shape[0], 1)), X]).tolist(), rep_type=cdd.RepType.GENERATOR)
                M = np.array(cdd.copy_inequalities(cdd.polyhedron_from_matrix(mat)).array)
                return unit_rows(-M[:, 1:], M[:, 0])

            out["pycddlib"] = cdd_vh
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda X: (lambda H: unit_rows(H.A, H.b))(pc.qhull(X))
        out["scipy"] = lambda X: (lambda eq: np.unique(np.round(unit_rows(eq[:, :-1], -eq[:, -1]), 12), axis=0))(ConvexHull(X).equations)
    elif op == "volume":
        out["hybobs"] = lambda A, b: Polytope(A, b).volume("exact").value
        out["hybobs_lp_path"] = lambda A, b: _lp_path(lambda: Polytope(A, b).volume("exact").value)
        if have_cdd:
            out["pycddlib+qhull"] = lambda A, b: ConvexHull(cdd_vertices(A, b)).volume
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda A, b: pc.volume(pc.Polytope(A, b), seed=0)
        out["scipy"] = lambda A, b: ConvexHull(scipy_halfspaces(A, b).intersections).volume
    elif op == "projection_2d":
        out["hybobs"] = lambda A, b: (lambda Q: (Q.A, Q.b))(Polytope(A, b).project([0, 1]))
        out["hybobs_lp_hull"] = lambda A, b: (lambda Q: (Q.A, Q.b))(Polytope(A, b).project([0, 1], method="hull"))
        if have_cdd:
            import cdd

            def cdd_vertices_hull(A, b):
                eq = ConvexHull(cdd_vertices(A, b)[:, :2]).equations
                return eq[:, :-1], -eq[:, -1]

            out["limit_cdd"] = cdd_vertices_hull

            def cdd_proj(A, b):
                mat = cdd.matrix_from_array(np.hstack([b[:, None], -A]).tolist(), rep_type=cdd.RepType.INEQUALITY)
                M = np.array(cdd.block_elimination(mat, set(range(3, A.shape[1] + 1))).array)
                return -M[:, 1:], M[:, 0]

            out["pycddlib"] = cdd_proj
        if have_pc:
            import polytope as pc

            out["polytope"] = lambda A, b: (lambda Q: (Q.A, Q.b))(pc.projection(pc.Polytope(A, b), [1, 2]))

        def scipy_proj(A, b):
            eq = ConvexHull(scipy_halfspaces(A, b).intersections[:, :2]).equations
            return eq[:, :-1], -eq[:, -1]

        out["limit_qhull"] = scipy_proj
    return out


def _lp_path(fn):
    with library_paths_disabled():
        return fn()


# ---------------------------------------------------------------------- one operation
def run_op(op: str, dims, n_instances: int, repeats: int, have_cdd: bool, have_pc: bool, lp_path_max_dim: dict) -> dict:
    from scipy.spatial import ConvexHull

    from hybobs_opt.geometry.vertices import COUNTERS

    impls = implementations(op, have_cdd, have_pc)
    per_dim = {}
    too_slow: dict[str, str] = {}
    for d in dims:
        rng = np.random.default_rng(1900 + 10 * d + list(DIMS).index(d))
        instances = []
        kinds = []
        if op == "v_to_h_degenerate":
            for kind in DEGENERATE_KINDS[:max(n_instances, 1)]:
                X, ref = degenerate_points(np.random.default_rng(3900 + 10 * d + len(kinds)), d, kind)
                instances.append(((X,), ref, 2.0))
                kinds.append(kind)
        for _ in range(n_instances if op != "v_to_h_degenerate" else 0):
            if op == "v_to_h":
                X = rng.normal(size=(4 * d + 10, d))
                X /= np.linalg.norm(X, axis=1)[:, None]
                X *= rng.uniform(0.5, 1.0, (X.shape[0], 1))
                eq = ConvexHull(X).equations
                ref = np.unique(np.round(unit_rows(eq[:, :-1], -eq[:, -1]), 12), axis=0)
                instances.append(((X,), ref, 2.0))
                kinds.append("random")
                continue
            A, b = random_polytope(rng, d)
            V = brute_force_vertices(A, b)
            size = float(np.max(V.max(axis=0) - V.min(axis=0)))
            if op == "vertices":
                ref = V
            elif op == "redundancy":
                k = lp_facets(A, b)
                ref = unit_rows(A[k], b[k])
            elif op == "volume":
                ref = ConvexHull(V).volume
            elif op == "chebyshev":
                ref = chebyshev_oracle(A, b)
            else:
                ref = V[:, :2][ConvexHull(V[:, :2]).vertices]
            instances.append(((A, b), ref, size))
            kinds.append("random")
        if op == "volume" and d == 6 and n_instances > 1:
            # the instance whose exact volume raised SolverError when issue 39 was filed (qhull's
            # triangulation of its 460 vertices did not sum to qhull's volume)
            A, b = random_polytope(np.random.default_rng(0), 6)
            V = brute_force_vertices(A, b)
            instances.append(((A, b), ConvexHull(V).volume, float(np.max(V.max(axis=0) - V.min(axis=0)))))
            kinds.append("issue39_solver_error")
        names = [n for n in impls if not (n == "hybobs_lp_path" and d > lp_path_max_dim.get(op, 0)) and n not in too_slow
                 and d <= PEER_MAX_DIM.get((op, n), 99)]
        times = {n: [[] for _ in instances] for n in names}
        answers = {n: [None] * len(instances) for n in names}
        errors = {}
        once = set()
        for n in names:  # warm-up on the first instance, not timed (numba kernels, imports)
            t0 = time.perf_counter()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    ans = impls[n](*instances[0][0])
            except Exception:  # recorded when timed below
                ans = None
            took = time.perf_counter() - t0
            if took > SKIP_SECONDS and not n.startswith("hybobs"):
                # far too slow to repeat: this call is its only measurement, on the first instance
                too_slow[n] = f"skipped above d = {d}: one call took {took:.0f} s"
                once.add(n)
                times[n][0].append(took)
                answers[n][0] = ans
        COUNTERS.reset()
        apart = [n for n in names if n in TIMED_APART.get(op, ())]
        blocks = [[n for n in names if n not in apart]] + [[n] for n in apart]
        for block, (k, (args, _, _)) in ((blk, inst) for blk in blocks for inst in enumerate(instances)):
            for r in range(repeats):
                for n in block:
                    if n in once or (r and (n in errors or (times[n][k] and times[n][k][0] > SLOW_SECONDS))):
                        continue
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            t0 = time.perf_counter()
                            ans = impls[n](*args)
                            times[n][k].append(time.perf_counter() - t0)
                        answers[n][k] = ans
                    except Exception as exc:  # a peer that fails is recorded, not fatal
                        errors.setdefault(n, f"{type(exc).__name__}: {str(exc)[:200]}")
        counters = COUNTERS.snapshot()
        res = {}
        for n in names:
            med, agree = [], []
            for k, (args, ref, size) in enumerate(instances):
                med.append(statistics.median(times[n][k]) if times[n][k] else None)
                agree.append(_agrees(op, answers[n][k], ref, size) if times[n][k] else None)
            res[n] = {"median_seconds_per_instance": med, "agrees_per_instance": agree,
                      "median_seconds": statistics.median([m for m in med if m is not None]) if any(m is not None for m in med) else None,
                      "all_agree": all(a for a in agree if a is not None), "calls_per_instance": [len(t) for t in times[n]]}
            if n in once:
                res[n]["note"] = "one call only (took more than SKIP_SECONDS), on the first instance"
            if n in errors:
                res[n]["error"] = errors[n]
        ratios, fastest = [], []
        for k in range(len(instances)):
            peers = [(res[n]["median_seconds_per_instance"][k], n) for n in names
                     if not n.startswith("hybobs") and res[n]["agrees_per_instance"][k]
                     and res[n]["median_seconds_per_instance"][k] is not None]
            ours = res["hybobs"]["median_seconds_per_instance"][k]
            if peers and ours is not None and res["hybobs"]["agrees_per_instance"][k]:
                t, n = min(peers)
                ratios.append(ours / t)
                fastest.append(n)
            else:
                ratios.append(None)
                fastest.append(None if not peers else min(peers)[1])
        valid = [r for r in ratios if r is not None]
        extra = {}
        for label, prefix in (("limit", "limit"), ("linprog", "linprog")):
            lim = [n for n in names if n.startswith(prefix)]
            if not lim:
                continue
            rl = []
            for k in range(len(instances)):
                ts = [res[n]["median_seconds_per_instance"][k] for n in lim
                      if res[n]["agrees_per_instance"][k] and res[n]["median_seconds_per_instance"][k] is not None]
                ours = res["hybobs"]["median_seconds_per_instance"][k]
                ok = ours is not None and res["hybobs"]["agrees_per_instance"][k]
                rl.append(ours / min(ts) if ts and ok else None)
            vl = [r for r in rl if r is not None]
            extra[f"ratio_to_{label}_per_instance"] = rl
            extra[f"median_ratio_to_{label}"] = statistics.median(vl) if vl else None
        target = OP_TARGETS.get(op, ("fastest_correct_peer", TARGET_RATIO))
        key = "median_ratio" if target[0] == "fastest_correct_peer" else f"median_ratio_to_{target[0]}"
        median_target = statistics.median(valid) if (valid and key == "median_ratio") else extra.get(key)
        per_dim[str(d)] = {
            "instance_kinds": kinds,
            **extra,
            "target": f"{key} <= {target[1]}",
            "n_instances": len(instances), "repeats": repeats,
            "instance_size": {"rows": int(instances[0][0][0].shape[0]), "dim": d} if not op.startswith("v_to_h")
            else {"points": [int(inst[0][0].shape[0]) for inst in instances], "dim": d},
            "implementations": res,
            "ratio_to_fastest_correct_peer_per_instance": ratios,
            "fastest_correct_peer_per_instance": fastest,
            "median_ratio": statistics.median(valid) if valid else None,
            "meets_target": median_target is not None and median_target <= target[1]
                            and all(res["hybobs"]["agrees_per_instance"]) and "error" not in res["hybobs"],
            "library_counters": counters,
            "skipped": {n: why for n, why in too_slow.items() if n not in names},
        }
        summary = {n: (round(res[n]["median_seconds"] * 1e3, 3) if res[n]["median_seconds"] else None) for n in names}
        log(f"{op} d={d}: ms {summary}; ratio {per_dim[str(d)]['median_ratio']}; {key} {median_target}; "
            f"agree {[n for n in names if res[n]['all_agree']]}; fallbacks {counters['fallbacks']}")
    return per_dim


def _agrees(op: str, ans, ref, size: float) -> bool:
    if ans is None:
        return False
    try:
        if op == "vertices":
            return same_points(ans, ref, size)
        if op in ("redundancy", "v_to_h", "v_to_h_degenerate"):
            return same_rows(ans, ref, size)
        if op == "chebyshev":
            (A, b), r_ref = ref
            centre, r = ans
            # the radius agrees with the oracle's, and the ball of the returned centre is inside
            return abs(r - r_ref) <= 1e-7 * max(1.0, abs(r_ref)) and bool(
                np.all(A @ np.asarray(centre, float) + np.linalg.norm(A, axis=1) * r <= b + 1e-7 * (1 + np.abs(b))))
        if op == "volume":
            return abs(float(ans) - ref) <= 1e-9 * ref
        H, h = ans
        return same_points(polygon_vertices(H, h), ref, size)
    except Exception:  # a malformed answer is a disagreement
        return False


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_polytope")
    parser.add_argument("--quick", action="store_true", help="small smoke run (d = 2, 4; one instance)")
    parser.add_argument("--ops", "--only", dest="ops", default="vertices,redundancy,v_to_h,v_to_h_degenerate,volume,chebyshev,projection_2d")
    parser.add_argument("--dims", default=None,
                        help="comma-separated dimensions (a partial run: its per-dimension results are merged into "
                             "results/polytope.json, each with the commit and load of its run; the others are kept)")
    args = parser.parse_args(argv)
    dims = (2, 4) if args.quick else DIMS
    if args.dims:
        dims = tuple(int(x) for x in args.dims.split(","))
    n_instances = 1 if args.quick else 3
    repeats = 3 if args.quick else 9
    try:
        import cdd  # noqa: F401

        have_cdd = True
    except ImportError:
        have_cdd = False
    try:
        import polytope  # noqa: F401

        have_pc = True
        pc_note = "installed into the venv for this benchmark only (an optional peer, not a dependency)"
    except ImportError as exc:
        have_pc = False
        pc_note = f"not importable: {exc} (pip install polytope into the venv to include it)"
    # the hand-written path is timed where it finishes in seconds
    lp_path_max_dim = {"vertices": 4, "redundancy": 6, "v_to_h": 6, "v_to_h_degenerate": 4, "volume": 4}
    load_start = _load()
    t0 = time.perf_counter()
    ops = {}
    for op in args.ops.split(","):
        ops[op] = run_op(op, dims, n_instances, repeats, have_cdd, have_pc, lp_path_max_dim)
    record = {
        "benchmark": "polytope operations: hybobs_opt.geometry vs pycddlib, the polytope package and scipy (issues 19, 39)",
        "target": (f"hybobs within {TARGET_RATIO} x of the fastest correct peer, results agreeing; Chebyshev ball "
                   "within 1.5 x a bare linprog; projection to 2-D within 3 x the limit (per dimension: 'target', 'meets_target')"),
        "protocol": ("each instance: every implementation called in turn, `repeats` rounds (slow ones once; the ones of "
                     "TIMED_APART, which never agree with the oracle, in a block of their own afterwards); "
                     "median per instance; ratio = hybobs / fastest peer that agrees with the oracle on that instance; "
                     "median_ratio over the instances of one dimension"),
        "oracles": {"vertices": "brute force over all d-subsets of rows (numpy)",
                    "v_to_h_degenerate": "the known facets: the rotated cube's 2 d rows, or the LP-irredundant rows of the polytope whose brute-force vertices are the points",
                    "chebyshev": "HiGHS interior-point radius (1e-7) and the returned centre's ball inside the set",
                    "redundancy": "linprog per row (facet iff its max over the others exceeds its bound)",
                    "v_to_h": "scipy ConvexHull facets merged", "volume": "ConvexHull of the brute-force vertices",
                    "projection_2d": "2-D hull of the projected brute-force vertices"},
        "peer_notes": {
            "pycddlib": "pycddlib-standalone (float cddlib), answers taken unchecked",
            "polytope": pc_note + "; its volume is Monte Carlo (default sample size), so it never agrees to 1e-9",
            "scipy": "Chebyshev centre by linprog (HiGHS), then qhull's HalfspaceIntersection / ConvexHull",
            "hybobs_lp_path": "the hand-written path the library path replaced (libraries disabled)",
            "hybobs_lp_hull": "Polytope.project(method='hull'): the LP iterative hull (the path of 'auto' before issue 39)",
            "limit_cdd": "the projection's limit: cddlib's vertices (unchecked), projected, scipy ConvexHull in 2-D",
            "limit_qhull": "the projection's limit: linprog centre, qhull HalfspaceIntersection, projected, ConvexHull in 2-D",
            "linprog": "the Chebyshev LP posed directly to scipy.optimize.linprog (HiGHS), unchecked",
        },
        "quick": args.quick,
        "git": git_state("hybobs_opt/geometry"),
        "operations": ops,
        "machine": {**machine(), "load_average_at_end": _load(), "load_average_at_start_of_run": load_start,
                    "versions": versions(("numpy", "scipy", "pycddlib-standalone", "pycddlib", "polytope"))},
        "wall_seconds": time.perf_counter() - t0,
    }
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "polytope.json"
    if args.dims and not args.quick and path.exists():
        # a partial run: merge its dimensions into the full run's record, each marked with its own run
        part = {"ops": list(ops), "dims": list(dims), "git": record["git"], "wall_seconds": record["wall_seconds"],
                "load_average_at_start": load_start, "load_average_at_end": record["machine"]["load_average_at_end"],
                "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        old = json.loads(path.read_text())
        for op, per_dim in ops.items():
            for d, entry in per_dim.items():
                old.setdefault("operations", {}).setdefault(op, {})[d] = {**entry, "partial_run": part}
        old.setdefault("partial_runs", []).append(part)
        record = old
    path.write_text(json.dumps(record, indent=1, default=json_default))
    log(f"wrote {path} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
