"""Paper 002, Section 6: the data of the region figures (Figs. 3-6) of models (16) and (17).

The cut planes (``omega_l = 25`` rad/s with the theta axis stretched x10 for model (16), the
Fig. 6 plane of model (17)) and the helpers that place them: the range of a state over ``X*_T``
(:func:`feasible_interval`), the backlash band of a cut (:func:`band_mask`), the dimensions of
the projections Algorithm 3.1 discards (:func:`reduced_pair_dimensions`) and the Fig. 6 planes
(:func:`fig6_planes`).  Shared with the report (section "Observability regions"),
``benchmarks/bench_regions.py`` and ``notebooks/02_observability_regions.ipynb``.
"""

from __future__ import annotations

import numpy as np

from hybobs_opt.geometry.lp import row_range, solve_lp
from hybobs_opt.regions import Cut
from hybobs_opt.regions.enumeration import horizon_scaling
from hybobs_opt.tolerances import REGION_SLACK_TOL

#: Section 6.1: cuts of model (16) through the plane omega_l = 25 rad/s, theta axis x10.
OMEGA_L_CUT = 25.0
THETA_STRETCH = 10.0
#: Section 6.2: the plane of the Fig. 6 cuts of model (17), in (theta_cl, omega_c).
FIG6_PLANE = {"theta_mc": 0.0, "omega_m": 90.0, "omega_l": 30.0}


def feasible_interval(analysis, state: str, fixed: dict[str, float]) -> tuple[float, float] | None:
    """Range of ``state`` over ``X*_T`` (eq. 5) intersected with ``fixed``; ``None`` if empty.

    Two LPs (:func:`hybobs_opt.geometry.lp.row_range`, coordinates scaled by the bounds) per region ``P_k`` of eq. (4).
    """
    enum = analysis.enumeration
    names = analysis.system.state_names
    k = names.index(state)
    scale, centre = enum.scale, enum.centre
    d = scale.size
    A_eq = np.zeros((len(fixed), d))
    b_eq = np.zeros(len(fixed))
    for r, (nm, v) in enumerate(fixed.items()):
        idx = names.index(nm)
        A_eq[r, idx] = scale[idx]
        b_eq[r] = v - centre[idx]
    lo, hi = np.inf, -np.inf
    for idx_r, reg in enumerate(enum.regions):
        G = reg.H * scale[None, :]
        g = reg.h - reg.H @ centre
        r = row_range(G, g, np.eye(1, d, k), E=A_eq if len(fixed) else None, e=b_eq if len(fixed) else None,
                      problem=f"range of {state} over P_{idx_r}", allow_empty=True, allow_unbounded=True)
        if r is None or not np.all(np.isfinite(r)):
            continue
        lo = min(lo, centre[k] + scale[k] * r[0, 0])
        hi = max(hi, centre[k] + scale[k] * r[0, 1])
    return None if lo > hi else (float(lo), float(hi))


def band_mask(cut: Cut, alpha: float, state: str = "theta") -> np.ndarray:
    """Grid points of ``cut`` inside the backlash band ``|state| < alpha``."""
    if cut.axes[0] == state:
        return np.broadcast_to(np.abs(cut.x_values)[None, :] < alpha, cut.labels.shape)
    return np.broadcast_to(np.abs(cut.y_values)[:, None] < alpha, cut.labels.shape)


def reduced_pair_dimensions(analysis, tol: float = REGION_SLACK_TOL) -> dict[int, int]:
    """``{dim Proj_x(R_ij): count}`` over the non-empty (closed) ``R_ij``, ``i`` in ``I``, ``j`` not in ``I``.

    Algorithm 3.1 keeps only full-dimensional projections (dimension ``n``); the lower-dimensional
    ones are the measure-zero sets it discards by design.  The dimension of the affine hull of the
    projection is found with LPs: maximise and minimise ``c'x`` over ``R_ij`` for directions ``c``
    orthogonal to the extent found so far (scaled coordinates, extent threshold ``tol``).
    """
    from hybobs_opt.regions.pair_sets import pair_constraints

    n = analysis.system.n
    scale, centre = horizon_scaling(analysis.system, analysis.T, copies_of_x=2)
    out: dict[int, int] = {}
    regions = analysis.regions
    for i in analysis.index_set:
        for j in analysis.rank_deficient:
            G, g, E, e = pair_constraints(regions[i], regions[j], n)
            Gs, gs = G * scale[None, :], g - G @ centre
            Es, es = E * scale[None, :], e - E @ centre
            first = solve_lp(np.zeros(scale.size), Gs, gs, Es, es, problem=f"R_{i},{j} non-empty")
            if first.status != "optimal":
                continue
            x0 = first.x[:n]
            extent: list[np.ndarray] = []
            flat: list[np.ndarray] = []
            while len(extent) + len(flat) < n:
                known = np.array(extent + flat).reshape(-1, n)
                # next direction: orthogonal to everything found so far
                basis = np.linalg.svd(known)[2][known.shape[0]:] if known.size else np.eye(n)
                cdir = basis[0]
                moved = None
                for sign in (1.0, -1.0):
                    c = np.zeros(scale.size)
                    c[:n] = sign * cdir
                    res = solve_lp(c, Gs, gs, Es, es, problem=f"extent of Proj_x R_{i},{j}")
                    if res.status == "optimal" and abs(cdir @ (res.x[:n] - x0)) > tol:
                        moved = res.x[:n] - x0
                        break
                if moved is None:
                    flat.append(cdir)
                else:
                    extent.append(moved / np.linalg.norm(moved))
            dim = len(extent)
            out[dim] = out.get(dim, 0) + 1
    return dict(sorted(out.items()))


def fig6_planes(analysis) -> dict:
    """The paper's Fig. 6 plane and, when it misses ``X*_T``, the nearest speed-consistent one.

    Returns ``{"paper": {...}, "paper_omega_c_range": range or None, "omega_l_range": range of
    omega_l over X*_T at theta_mc = 0, omega_m = 90, "consistent": plane or None,
    "consistent_omega_c_range": range}``; the consistent plane moves ``omega_l`` to the midpoint
    of its feasible range (all ranges by LP, :func:`feasible_interval`).
    """
    paper = dict(FIG6_PLANE)
    out = {"paper": paper, "paper_omega_c_range": feasible_interval(analysis, "omega_c", paper)}
    keep = {k: v for k, v in paper.items() if k != "omega_l"}
    wl = feasible_interval(analysis, "omega_l", keep)
    out["omega_l_range"] = wl
    out["consistent"] = None
    out["consistent_omega_c_range"] = None
    if wl is not None:
        plane = {**keep, "omega_l": 0.5 * (wl[0] + wl[1])}
        out["consistent"] = plane
        out["consistent_omega_c_range"] = feasible_interval(analysis, "omega_c", plane)
    return out
