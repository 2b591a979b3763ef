"""Peers for one window of the moving-horizon observer (10) of paper 002, posed from the plant data.

Independent of ``hybobs_opt/mhe``: only the :class:`PWASystem`'s matrices are read (like
``tests/mhe_exact_reference.py``).  One window of eq. (10) of Bemporad, Ferrari-Trecate & Morari
(2000), with the observer's defaults (no output weight, no disturbances, no arrival cost):

``min over x(0), q  sum_k ||y(k) - C_{q_k} x(k) - D_{q_k} u(k) - c_{q_k}||``  (2-norm squared:
MIQP; 1-norm or inf-norm: MILP)

subject to ``x(k + 1) = A_{q_k} x(k) + B_{q_k} u(k) + a_{q_k}``, ``[x(k); u(k)] in Q_{q_k}`` (the
guard of mode ``q_k``) and ``x(k) in X`` for ``k = 0..T-1``.

Formulation (one binary ``d[k, i]`` per mode and step, ``sum_i d[k, i] = 1``): the states in the
unit coordinates ``xi`` of the bounding box of ``X`` (``x = c + h xi``, box from ``2 n`` LPs),
``X`` itself as rows when it is not that box; per mode and step, the guard rows, the dynamics
equalities and the residual ``e(k) = y(k) - C_i x(k) - D_i u(k) - c_i`` either

* ``"bigm"``: relaxed by ``M (1 - d[k, i])``, each ``M`` the row's exact range over the box
  (interval arithmetic; the inputs are data), or
* ``"indicator"``: Gurobi indicator constraints ``d[k, i] = 1 -> row`` (SCIP: big-M only).

The residual ``e(k)`` is a variable bounded by the hull of its modes' ranges over the box; the
cost is ``sum e^2`` (norm ``"2"``), ``sum t`` with ``-t <= e <= t`` (``"1"``) or ``t`` with
``-t <= e <= t`` for every entry (``"inf"``).

Solvers: gurobipy (``Threads = 1``, ``MIPGap = 0``, ``MIPGapAbs = 0``; ``IntFeasTol`` and
``FeasibilityTol`` at ``1e-9`` by default, since a binary at ``1 - 1e-5`` times a big-M of the
size of the state box would otherwise leak several noise levels into the dynamics) on the
size-limited licence shipped with the wheel (:data:`GUROBI_SIZE_LIMIT` variables and rows: a
window is refused with its size beforehand when it does not fit), and PySCIPOpt for the MILP
(``limits/gap = 0``, ``limits/absgap = 0``, one thread).  The answer is re-checked in numpy: the
solver's window-start state and mode sequence are simulated through the model, the cost
recomputed (``cost``) and the largest guard / ``X`` violation along that trajectory reported
(``max_violation``, original units).

The uniqueness question behind the observer's flag is posed the same way by
:func:`separated_minimum_gurobi`: the least cost of a window trajectory with a state at least
``delta`` away from given states at the same step (``|xi_k,j - xi*_k,j| >= delta`` in the unit
coordinates of the box, one binary per step, coordinate and side, big-M rows).

Exported: :func:`window_size`, :func:`solve_window_gurobi`, :func:`solve_window_scip`,
:func:`separated_minimum_gurobi`,
:func:`gurobi_available`, :func:`scip_available`, :class:`PeerWindow`, :class:`PeerResult`,
:data:`GUROBI_SIZE_LIMIT`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog

__all__ = ["GUROBI_SIZE_LIMIT", "PeerResult", "PeerWindow", "gurobi_available", "scip_available",
           "separated_minimum_gurobi", "solve_window_gurobi", "solve_window_scip", "window_size"]

#: Largest number of variables and of linear constraints the size-limited Gurobi licence
#: shipped with the ``gurobipy`` wheel accepts (each).
GUROBI_SIZE_LIMIT = 2000
#: Gurobi's integrality and feasibility tolerances used by default (its smallest allowed values).
GUROBI_TOLS = {"IntFeasTol": 1e-9, "FeasibilityTol": 1e-9}
NORMS = ("2", "1", "inf")


def gurobi_available() -> bool:
    """Whether gurobipy imports (its licence is checked only when a model is solved)."""
    try:
        import gurobipy  # noqa: F401
    except Exception:
        return False
    return True


def scip_available() -> bool:
    """Whether PySCIPOpt imports."""
    try:
        import pyscipopt  # noqa: F401
    except Exception:
        return False
    return True


@dataclass
class PeerResult:
    """One window solved by a peer.

    ``status`` is ``"optimal"``, ``"infeasible"``, ``"not installed"``, ``"too large"`` (the size
    limit, ``reason`` has the figures) or the solver's own status name.  ``optimum`` is the
    solver's objective, ``bound`` its dual bound, ``cost`` the cost recomputed in numpy by
    simulating ``x_start`` through ``modes``; ``solver_seconds`` the solver's own time
    (``Model.Runtime`` / ``getSolvingTime``), ``build_seconds`` building the model in Python.
    """

    solver: str
    norm: str
    status: str
    optimum: float | None = None
    bound: float | None = None
    cost: float | None = None
    x_start: np.ndarray | None = None
    states: np.ndarray | None = None
    modes: tuple[int, ...] | None = None
    max_violation: float | None = None
    solver_seconds: float | None = None
    build_seconds: float | None = None
    wall_seconds: float | None = None
    nodes: float | None = None
    size: dict = field(default_factory=dict)
    reason: str | None = None

    def to_dict(self) -> dict:
        return {"solver": self.solver, "norm": self.norm, "status": self.status, "optimum": self.optimum,
                "bound": self.bound, "cost": self.cost,
                "x_start": None if self.x_start is None else self.x_start.tolist(),
                "modes": None if self.modes is None else list(self.modes), "max_violation": self.max_violation,
                "solver_seconds": self.solver_seconds, "build_seconds": self.build_seconds,
                "wall_seconds": self.wall_seconds, "nodes": self.nodes, "size": dict(self.size), "reason": self.reason}


def _box_of(A, b) -> tuple[np.ndarray, np.ndarray]:
    """Bounding box of ``{x: A x <= b}`` by ``2 n`` LPs (HiGHS through scipy)."""
    n = A.shape[1]
    lo, hi = np.empty(n), np.empty(n)
    for j in range(n):
        for sign, out in ((1.0, lo), (-1.0, hi)):
            c = np.zeros(n)
            c[j] = sign
            lp = linprog(c, A_ub=A, b_ub=b, bounds=[(None, None)] * n, method="highs")
            if lp.status != 0:
                raise ValueError(f"the state set X is not bounded (LP status {lp.status}: {lp.message})")
            out[j] = lp.x[j]
    return lo, hi


def _range(Mx, const, lo=-1.0, hi=1.0):
    """Exact range of ``Mx xi + const`` (rows) over ``xi`` in ``[lo, hi]^n`` (interval arithmetic)."""
    spread = np.abs(Mx).sum(axis=1) * (hi - lo) / 2.0
    mid = Mx.sum(axis=1) * (hi + lo) / 2.0 + const
    return mid - spread, mid + spread


class PeerWindow:
    """The model data of eq. (10) for one system, read once (box of ``X``, mode matrices)."""

    def __init__(self, system):
        self.n, self.m, self.p = int(system.n), int(system.m), int(system.p)
        self.s = int(system.n_modes)
        self.XA = np.asarray(system.state_bounds.A, float)
        self.Xb = np.asarray(system.state_bounds.b, float)
        lo, hi = _box_of(self.XA, self.Xb)
        self.cx, self.hx = (lo + hi) / 2.0, (hi - lo) / 2.0
        self.UA = np.asarray(system.input_bounds.A, float)
        self.Ub = np.asarray(system.input_bounds.b, float)
        self.modes = [tuple(np.asarray(v, float) for v in (md.A, md.B, md.a, md.C, md.D, md.c, md.guard.A, md.guard.b))
                      for md in system.modes]
        # rows of X not implied by the box (X is often the box itself: then none)
        XAs = self.XA * self.hx[None, :]
        xb = self.Xb - self.XA @ self.cx
        _, top = _range(XAs, np.zeros(len(xb)))
        keep = top > xb + 1e-12 * (1.0 + np.abs(xb))
        self.XAs, self.Xbs = XAs[keep], xb[keep]

    # ------------------------------------------------------------------ numpy model
    def simulate(self, x0, modes, U) -> np.ndarray:
        X = np.empty((len(modes), self.n))
        X[0] = x0
        for k in range(len(modes) - 1):
            A, B, a = self.modes[modes[k]][:3]
            X[k + 1] = A @ X[k] + B @ U[k] + a
        return X

    def residuals(self, x0, modes, U, Y) -> np.ndarray:
        X = self.simulate(x0, modes, U)
        return np.array([Y[k] - self.modes[q][3] @ X[k] - self.modes[q][4] @ U[k] - self.modes[q][5]
                         for k, q in enumerate(modes)])

    def cost(self, x0, modes, U, Y, norm: str) -> float:
        E = self.residuals(x0, modes, U, Y)
        if norm == "2":
            return float(np.sum(E * E))
        if norm == "1":
            return float(np.sum(np.abs(E)))
        return float(np.max(np.abs(E)))

    def violation(self, x0, modes, U) -> float:
        X = self.simulate(x0, modes, U)
        worst = 0.0
        for k, q in enumerate(modes):
            G, g = self.modes[q][6:8]
            worst = max(worst, float(np.max(G @ np.concatenate([X[k], U[k]]) - g, initial=0.0)),
                        float(np.max(self.XA @ X[k] - self.Xb, initial=0.0)))
        return worst

    # ------------------------------------------------------------------ the program
    def program(self, U, Y, norm: str = "2") -> dict:
        """Eq. (10) of one window as numpy data: variables ``[xi (T n), d (T s), e (T p), t]``
        (``t``: ``T p`` entries for norm 1, one for inf, none for 2), their bounds and types, the
        big-M rows ``lo <= A v <= hi``, and the indicator rows ``(binary, a, sense, rhs)``."""
        U, Y = np.atleast_2d(np.asarray(U, float)), np.atleast_2d(np.asarray(Y, float))
        if norm not in NORMS:
            raise ValueError(f"norm must be one of {NORMS}, got {norm!r}")
        T, n, p, s = U.shape[0], self.n, self.p, self.s
        if Y.shape != (T, p) or U.shape[1] != self.m:
            raise ValueError(f"U must be (T, {self.m}) and Y (T, {p}); got {U.shape} and {Y.shape}")
        for k in range(T):
            if np.any(self.UA @ U[k] > self.Ub + 1e-9 * (1.0 + np.abs(self.Ub))):
                raise ValueError(f"the input u({k}) = {U[k].tolist()} is outside U")
        nt = {"2": 0, "1": T * p, "inf": 1}[norm]
        ix = lambda k: slice(k * n, (k + 1) * n)  # noqa: E731
        idd = lambda k, i: T * n + k * s + i  # noqa: E731
        ie = lambda k: slice(T * n + T * s + k * p, T * n + T * s + (k + 1) * p)  # noqa: E731
        it0 = T * n + T * s + T * p
        nv = it0 + nt
        lb, ub = np.full(nv, -np.inf), np.full(nv, np.inf)
        lb[: T * n], ub[: T * n] = -1.0, 1.0
        lb[T * n: T * n + T * s], ub[T * n: T * n + T * s] = 0.0, 1.0
        vtype = np.array(["C"] * nv)
        vtype[T * n: T * n + T * s] = "B"
        lb[it0:] = 0.0
        big: list[tuple[np.ndarray, float, float]] = []  # (row, lo, hi)
        ind: list[tuple[int, np.ndarray, str, float]] = []  # (binary, row, sense, rhs)
        H = np.diag(self.hx)

        def row():
            return np.zeros(nv)

        def relaxed(k, i, a, lo_r, hi_r, rmin, rmax):
            """``lo_r <= a v <= hi_r`` when ``d[k, i] = 1``; ``a v`` ranges over ``[rmin, rmax]``."""
            d = idd(k, i)
            if np.isfinite(hi_r):
                Mh = max(rmax - hi_r, 0.0)
                r = a.copy()
                r[d] += Mh  # a v + M d <= hi + M
                big.append((r, -np.inf, hi_r + Mh))
                ind.append((d, a, "<", hi_r))
            if np.isfinite(lo_r):
                Ml = max(lo_r - rmin, 0.0)
                r = a.copy()
                r[d] -= Ml  # a v - M d >= lo - M
                big.append((r, lo_r - Ml, np.inf))
                ind.append((d, a, ">", lo_r))

        # the residuals' bounds: hull over the modes of y - C x - D u - c over the box
        elo, ehi = np.full((T, p), np.inf), np.full((T, p), -np.inf)
        for k in range(T):
            for (A, B, a, C, D, c, G, g) in self.modes:
                rlo, rhi = _range(-C @ H, Y[k] - C @ self.cx - D @ U[k] - c)
                elo[k], ehi[k] = np.minimum(elo[k], rlo), np.maximum(ehi[k], rhi)
            lb[ie(k)], ub[ie(k)] = elo[k], ehi[k]
        for k in range(T):
            r = row()
            r[[idd(k, i) for i in range(s)]] = 1.0
            big.append((r, 1.0, 1.0))
            ind.append((-1, r, "=", 1.0))
            for j in range(len(self.Xbs)):
                r = row()
                r[ix(k)] = self.XAs[j]
                big.append((r, -np.inf, self.Xbs[j]))
                ind.append((-1, r, "<", self.Xbs[j]))
            for i, (A, B, a, C, D, c, G, g) in enumerate(self.modes):
                Gx, Gu = G[:, :n], G[:, n:]
                gk = g - Gu @ U[k] - Gx @ self.cx
                rmin, rmax = _range(Gx @ H, np.zeros(len(g)))
                for j in range(len(g)):
                    r = row()
                    r[ix(k)] = Gx[j] @ H
                    relaxed(k, i, r, -np.inf, gk[j], rmin[j], rmax[j])
                # e(k) + C h xi(k) = y - C c - D u - c_i
                rhs = Y[k] - C @ self.cx - D @ U[k] - c
                CH = C @ H
                for j in range(p):
                    r = row()
                    r[ie(k).start + j] = 1.0
                    r[ix(k)] = CH[j]
                    cmin, cmax = _range(CH[j:j + 1], np.zeros(1))
                    relaxed(k, i, r, rhs[j], rhs[j], elo[k, j] + cmin[0], ehi[k, j] + cmax[0])
                if k + 1 < T:
                    # h xi(k+1) - A h xi(k) = A c + B u + a - c
                    rhs = A @ self.cx + B @ U[k] + a - self.cx
                    AH = A @ H
                    for j in range(n):
                        r = row()
                        r[ix(k + 1).start + j] = self.hx[j]
                        r[ix(k)] = -AH[j]
                        rr = np.concatenate([-AH[j], [self.hx[j]]])
                        dmin = -np.abs(rr).sum()
                        relaxed(k, i, r, rhs[j], rhs[j], dmin, -dmin)
        for k in range(T):
            for j in range(p):
                for sign in (1.0, -1.0):
                    if norm == "2":
                        break
                    r = row()
                    r[ie(k).start + j] = sign
                    r[it0 + (k * p + j if norm == "1" else 0)] = -1.0
                    big.append((r, -np.inf, 0.0))
                    ind.append((-1, r, "<", 0.0))
        Q = np.zeros(nv)
        cvec = np.zeros(nv)
        if norm == "2":
            Q[T * n + T * s: it0] = 1.0
        else:
            cvec[it0:] = 1.0
        A_rows = np.array([b[0] for b in big])
        return {"T": T, "n": n, "s": s, "p": p, "nv": nv, "lb": lb, "ub": ub, "vtype": vtype, "Q": Q, "c": cvec,
                "A": A_rows, "lo": np.array([b[1] for b in big]), "hi": np.array([b[2] for b in big]),
                "indicators": ind, "xi": slice(0, T * n), "d": slice(T * n, T * n + T * s)}

    def decode(self, prog: dict, v: np.ndarray, U, Y, norm: str) -> dict:
        """Window-start state, modes, recomputed cost and violation of a solver's point ``v``."""
        T, n, s = prog["T"], prog["n"], prog["s"]
        xi = v[prog["xi"]].reshape(T, n)
        d = v[prog["d"]].reshape(T, s)
        modes = tuple(int(i) for i in np.argmax(d, axis=1))
        x0 = self.cx + self.hx * xi[0]
        U, Y = np.atleast_2d(np.asarray(U, float)), np.atleast_2d(np.asarray(Y, float))
        return {"x_start": x0, "modes": modes, "states": self.simulate(x0, modes, U),
                "cost": self.cost(x0, modes, U, Y, norm), "max_violation": self.violation(x0, modes, U),
                "integrality": float(np.max(np.abs(d - np.round(d))))}


def window_size(system_or_peer, T: int, norm: str = "2", formulation: str = "bigm") -> dict:
    """Variables, binaries and linear rows of one window (the size-limited licence counts
    variables and linear constraints; indicator constraints are general constraints)."""
    pw = system_or_peer if isinstance(system_or_peer, PeerWindow) else PeerWindow(system_or_peer)
    U = np.zeros((T, pw.m))
    # any input in U gives the same shape: take a point of U (its Chebyshev centre)
    nu = pw.UA.shape[1]
    lp = linprog(np.r_[np.zeros(nu), -1.0], A_ub=np.hstack([pw.UA, np.linalg.norm(pw.UA, axis=1)[:, None]]),
                 b_ub=pw.Ub, bounds=[(None, None)] * nu + [(None, 1.0)], method="highs")
    if lp.status == 0:
        U[:] = lp.x[:nu]
    prog = pw.program(U, np.zeros((T, pw.p)), norm)
    n_lin = int(sum(1 for b in prog["indicators"] if b[0] < 0)) if formulation == "indicator" else len(prog["lo"])
    return {"variables": prog["nv"], "binaries": T * pw.s, "linear_rows": n_lin,
            "quadratic_terms": int(np.count_nonzero(prog["Q"])),
            "indicators": int(sum(1 for b in prog["indicators"] if b[0] >= 0)) if formulation == "indicator" else 0}


def _peer(system) -> PeerWindow:
    return system if isinstance(system, PeerWindow) else PeerWindow(system)


def _gurobi_objective(prog: dict, x):
    """``c'x + sum_i Q_i x_i^2`` of a window's program (``Q`` diagonal) over Gurobi's variables ``x``."""
    Q = prog["Q"]
    obj = prog["c"] @ x
    if np.any(Q):
        qi = np.nonzero(Q)[0]
        obj = obj + (x[qi] * Q[qi]) @ x[qi]
    return obj


def solve_window_gurobi(system, U, Y, norm: str = "2", *, formulation: str = "bigm", threads: int = 1,
                        time_limit: float | None = None, params: dict | None = None) -> PeerResult:
    """One window of eq. (10) by Gurobi.  ``system``: a PWASystem or a :class:`PeerWindow` (reuse it:
    it holds the box LPs).  Refuses (status ``"too large"``) a window above :data:`GUROBI_SIZE_LIMIT`."""
    t_wall = time.perf_counter()
    try:
        import gurobipy as gp
        from gurobipy import GRB
    except Exception:
        return PeerResult("gurobi", norm, "not installed")
    pw = _peer(system)
    t0 = time.perf_counter()
    prog = pw.program(U, Y, norm)
    n_lin = len(prog["lo"]) if formulation == "bigm" else sum(1 for b in prog["indicators"] if b[0] < 0)
    size = {"variables": prog["nv"], "binaries": prog["T"] * prog["s"], "linear_rows": int(n_lin)}
    if prog["nv"] > GUROBI_SIZE_LIMIT or n_lin > GUROBI_SIZE_LIMIT:
        return PeerResult("gurobi", norm, "too large", size=size,
                          reason=f"{prog['nv']} variables and {n_lin} rows; the size-limited licence takes "
                                 f"{GUROBI_SIZE_LIMIT} of each")
    env = gp.Env(empty=True)
    env.setParam("OutputFlag", 0)
    env.start()
    try:
        mdl = gp.Model(env=env)
        mdl.Params.Threads = int(threads)
        mdl.Params.MIPGap = 0.0
        mdl.Params.MIPGapAbs = 0.0
        for k, v in {**GUROBI_TOLS, **(params or {})}.items():
            mdl.setParam(k, v)
        if time_limit is not None:
            mdl.Params.TimeLimit = float(time_limit)
        vt = [GRB.BINARY if t == "B" else GRB.CONTINUOUS for t in prog["vtype"]]
        x = mdl.addMVar(prog["nv"], lb=prog["lb"], ub=prog["ub"], vtype=vt)
        if formulation == "bigm":
            A, lo, hi = prog["A"], prog["lo"], prog["hi"]
            eq = lo == hi
            le = ~eq & np.isfinite(hi)
            ge = ~eq & np.isfinite(lo)
            if eq.any():
                mdl.addConstr(A[eq] @ x == hi[eq])
            if le.any():
                mdl.addConstr(A[le] @ x <= hi[le])
            if ge.any():
                mdl.addConstr(A[ge] @ x >= lo[ge])
        elif formulation == "indicator":
            xs = x.tolist()
            for b, a, sense, rhs in prog["indicators"]:
                nz = np.nonzero(a)[0]
                expr = gp.LinExpr(a[nz].tolist(), [xs[j] for j in nz])
                con = expr <= rhs if sense == "<" else (expr >= rhs if sense == ">" else expr == rhs)
                if b < 0:
                    mdl.addConstr(con)
                else:
                    mdl.addGenConstrIndicator(xs[b], True, con)
        else:
            raise ValueError(f"formulation must be 'bigm' or 'indicator', got {formulation!r}")
        mdl.setObjective(_gurobi_objective(prog, x), GRB.MINIMIZE)
        build = time.perf_counter() - t0
        mdl.optimize()
        st = mdl.Status
        res = PeerResult("gurobi", norm, {GRB.OPTIMAL: "optimal", GRB.INFEASIBLE: "infeasible"}.get(
            st, f"gurobi status {st}"), solver_seconds=float(mdl.Runtime), build_seconds=build,
            nodes=float(mdl.NodeCount), size=size)
        if st == GRB.OPTIMAL:
            res.optimum, res.bound = float(mdl.ObjVal), float(mdl.ObjBound)
            out = pw.decode(prog, np.asarray(x.X, float), U, Y, norm)
            res.x_start, res.modes, res.states = out["x_start"], out["modes"], out["states"]
            res.cost, res.max_violation = out["cost"], out["max_violation"]
        elif mdl.SolCount > 0:
            res.optimum, res.bound = float(mdl.ObjVal), float(mdl.ObjBound)
        mdl.dispose()
    except Exception as exc:  # the licence or the solver: reported, never raised into a benchmark
        return PeerResult("gurobi", norm, "error", reason=f"{type(exc).__name__}: {exc}", size=size,
                          wall_seconds=time.perf_counter() - t_wall)
    finally:
        env.dispose()
    res.wall_seconds = time.perf_counter() - t_wall
    return res


def solve_window_scip(system, U, Y, norm: str = "1", *, time_limit: float | None = None) -> PeerResult:
    """One window of eq. (10) by SCIP (big-M formulation; norms 1 / inf, or 2 as a MIQCP)."""
    t_wall = time.perf_counter()
    try:
        import pyscipopt as ps
    except Exception:
        return PeerResult("scip", norm, "not installed")
    pw = _peer(system)
    t0 = time.perf_counter()
    prog = pw.program(U, Y, norm)
    size = {"variables": prog["nv"], "binaries": prog["T"] * prog["s"], "linear_rows": len(prog["lo"])}
    try:
        mdl = ps.Model()
        mdl.hideOutput()
        mdl.setParam("limits/gap", 0.0)
        mdl.setParam("limits/absgap", 0.0)
        mdl.setParam("parallel/maxnthreads", 1)
        mdl.setParam("numerics/feastol", 1e-9)
        if time_limit is not None:
            mdl.setParam("limits/time", float(time_limit))
        xs = [mdl.addVar(lb=None if not np.isfinite(prog["lb"][j]) else float(prog["lb"][j]),
                         ub=None if not np.isfinite(prog["ub"][j]) else float(prog["ub"][j]),
                         vtype="B" if prog["vtype"][j] == "B" else "C") for j in range(prog["nv"])]
        for a, lo, hi in zip(prog["A"], prog["lo"], prog["hi"]):
            nz = np.nonzero(a)[0]
            expr = ps.quicksum(float(a[j]) * xs[j] for j in nz)
            if lo == hi:
                mdl.addCons(expr == float(hi))
            elif np.isfinite(hi):
                mdl.addCons(expr <= float(hi))
            else:
                mdl.addCons(expr >= float(lo))
        Q, c = prog["Q"], prog["c"]
        if np.any(Q):  # SCIP wants a linear objective: an epigraph variable
            z = mdl.addVar(lb=0.0, ub=None)
            mdl.addCons(ps.quicksum(float(Q[j]) * xs[j] * xs[j] for j in np.nonzero(Q)[0]) <= z)
            mdl.setObjective(z, "minimize")
        else:
            mdl.setObjective(ps.quicksum(float(c[j]) * xs[j] for j in np.nonzero(c)[0]), "minimize")
        build = time.perf_counter() - t0
        mdl.optimize()
        st = mdl.getStatus()
        res = PeerResult("scip", norm, {"optimal": "optimal", "infeasible": "infeasible"}.get(st, f"scip status {st}"),
                         solver_seconds=float(mdl.getSolvingTime()), build_seconds=build,
                         nodes=float(mdl.getNNodes()), size=size)
        if st == "optimal":
            res.optimum, res.bound = float(mdl.getObjVal()), float(mdl.getDualbound())
            sol = mdl.getBestSol()
            out = pw.decode(prog, np.array([mdl.getSolVal(sol, v) for v in xs]), U, Y, norm)
            res.x_start, res.modes, res.states = out["x_start"], out["modes"], out["states"]
            res.cost, res.max_violation = out["cost"], out["max_violation"]
    except Exception as exc:
        return PeerResult("scip", norm, "error", reason=f"{type(exc).__name__}: {exc}", size=size,
                          wall_seconds=time.perf_counter() - t_wall)
    res.wall_seconds = time.perf_counter() - t_wall
    return res


def separated_minimum_gurobi(system, U, Y, norm: str, states, delta: float, *, time_limit: float | None = None) -> dict:
    """The least cost of eq. (10) over window trajectories with some state at least ``delta``
    away from ``states`` (original units, ``(T, n)``) at the same step, inf-norm in the unit
    coordinates ``xi`` of the box of ``X``: the program of :meth:`PeerWindow.program` plus
    ``2 n T`` binaries ``b`` with ``sum b = 1`` and ``sign (xi_k,j - xi*_k,j) >= delta - M (1 - b)``
    (``M = delta + 2``: ``xi`` and ``xi*`` lie in ``[-1, 1]``).  Gurobi as in
    :func:`solve_window_gurobi`.  Returns ``status``, ``minimum`` and ``bound`` (Gurobi's, ``inf``
    when infeasible), ``cost`` and ``distance`` of its point recomputed in numpy, ``seconds``."""
    try:
        import gurobipy as gp
        from gurobipy import GRB
    except Exception:
        return {"status": "not installed"}
    pw = _peer(system)
    prog = pw.program(U, Y, norm)
    T, n = prog["T"], prog["n"]
    xs = np.clip((np.asarray(states, float) - pw.cx) / pw.hx, -1.0, 1.0)
    M = delta + 2.0
    env = gp.Env(empty=True)
    env.setParam("OutputFlag", 0)
    env.start()
    try:
        mdl = gp.Model(env=env)
        mdl.Params.Threads = 1
        mdl.Params.MIPGap = 0.0
        mdl.Params.MIPGapAbs = 0.0
        for k, v in GUROBI_TOLS.items():
            mdl.setParam(k, v)
        if time_limit is not None:
            mdl.Params.TimeLimit = float(time_limit)
        vt = [GRB.BINARY if t == "B" else GRB.CONTINUOUS for t in prog["vtype"]]
        x = mdl.addMVar(prog["nv"], lb=prog["lb"], ub=prog["ub"], vtype=vt)
        A, lo, hi = prog["A"], prog["lo"], prog["hi"]
        eq = lo == hi
        le, ge = ~eq & np.isfinite(hi), ~eq & np.isfinite(lo)
        mdl.addConstr(A[eq] @ x == hi[eq])
        mdl.addConstr(A[le] @ x <= hi[le])
        mdl.addConstr(A[ge] @ x >= lo[ge])
        # a side whose delta-shift leaves the box has no point: its binary is fixed at 0
        room = np.stack([xs + delta <= 1.0, xs - delta >= -1.0], axis=-1).reshape(-1)
        b = mdl.addMVar(2 * n * T, lb=0.0, ub=room.astype(float), vtype=GRB.BINARY)
        mdl.addConstr(b.sum() == 1.0)
        xsl = x.tolist()
        bl = b.tolist()
        for k in range(T):
            for j in range(n):
                for side, sg in enumerate((1.0, -1.0)):
                    d = 2 * (k * n + j) + side
                    mdl.addConstr(sg * xsl[k * n + j] - M * bl[d] >= delta - M + sg * xs[k, j])
        mdl.setObjective(_gurobi_objective(prog, x), GRB.MINIMIZE)
        mdl.optimize()
        st = mdl.Status
        out = {"status": {GRB.OPTIMAL: "optimal", GRB.INFEASIBLE: "infeasible"}.get(st, f"gurobi status {st}"),
               "seconds": float(mdl.Runtime), "minimum": None, "bound": None}
        if st == GRB.INFEASIBLE:
            out["minimum"] = out["bound"] = float("inf")
        elif st == GRB.OPTIMAL:
            out["minimum"], out["bound"] = float(mdl.ObjVal), float(mdl.ObjBound)
            dec = pw.decode(prog, np.asarray(x.X, float), U, Y, norm)
            out["cost"], out["max_violation"] = dec["cost"], dec["max_violation"]
            out["distance"] = float(np.max(np.abs((dec["states"] - pw.cx) / pw.hx - xs)))
        mdl.dispose()
        return out
    except Exception as exc:  # the licence or the solver: reported, never raised into a benchmark
        return {"status": "error", "reason": f"{type(exc).__name__}: {exc}"}
    finally:
        env.dispose()
