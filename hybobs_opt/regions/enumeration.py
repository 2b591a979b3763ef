"""Mode enumeration over a horizon T: the regions P_i and output maps of eq. (4), paper 002.

For every mode sequence ``sigma = (i_0, ..., i_{T-1})`` the state is affine in ``(x, U)``,
``x(k) = Phi_k x + Gamma_k U + phi_k``, so the set of ``(x, U)`` that follow ``sigma`` is a
polytope ``P_sigma`` and the output sequence is ``Y = C_sigma x + D_sigma U + f_sigma`` on it.
Sequences are enumerated as a prefix tree: a prefix whose polytope is empty (or thinner than
:data:`~hybobs_opt.tolerances.REGION_SLACK_TOL` in scaled coordinates) is pruned with one LP,
together with its whole subtree.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..geometry._reproducible import matmul as mm
from ..geometry.lp import counting_lps, max_slack
from ..systems.pwa import PWASystem
from ..tolerances import BOX_IMPLIED_RTOL, REGION_SLACK_TOL


@dataclass(frozen=True, eq=False)
class ModeRegion:
    """One region ``P_i`` of eq. (4): a mode sequence, its polytope over ``(x, U)`` and output map.

    Parameters
    ----------
    sequence : tuple of int
        Modes ``i_0 ... i_{T-1}``.
    H, h : arrays
        ``P_i = {(x, U) : H [x; U] <= h}`` in original (unscaled) coordinates.
    C, D, f : arrays
        ``Y = C x + D U + f`` on ``P_i`` (``Y`` stacks ``y(0) ... y(T-1)``).
    Phi, Gamma, phi : arrays
        ``x(T) = Phi x + Gamma U + phi``: the state one step after the window.
    Phi_last, Gamma_last, phi_last : arrays
        ``x(T - 1) = Phi_last x + Gamma_last U + phi_last``: the state at the window's last sample,
        i.e. the current time of a moving-horizon observer (paper 002, Section 4).
    slack : float
        Chebyshev radius of ``P_i`` in scaled coordinates (certified lower bound).

    See Also
    --------
    enumerate_modes : the regions of a system.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import enumerate_modes
    >>> region = enumerate_modes(get_example("powertrain3").build(), 3).regions[0]
    >>> region.sequence                                 # three steps in mode 0 (negative contact)
    (0, 0, 0)
    >>> region.H.shape[1], region.Phi.shape            # polytope over (x, U); outputs Y = Phi x + ...
    (6, (3, 3))
    """

    sequence: tuple[int, ...]
    H: np.ndarray
    h: np.ndarray
    C: np.ndarray
    D: np.ndarray
    f: np.ndarray
    Phi: np.ndarray
    Gamma: np.ndarray
    phi: np.ndarray
    slack: float
    Phi_last: np.ndarray | None = None
    Gamma_last: np.ndarray | None = None
    phi_last: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class ModeEnumeration:
    """Result of :func:`enumerate_modes`: the regions of eq. (4) for horizon ``T``.

    ``scale``/``centre`` map scaled coordinates ``w in [-1, 1]`` of ``(x, U)`` to original ones,
    ``z = centre + scale * w``.

    Parameters
    ----------
    system : PWASystem
        The system.
    T : int
        Horizon.
    regions : tuple of ModeRegion
        The non-empty regions, in lexicographic order of their mode sequences.
    scale, centre : arrays
        The map above, over ``(x, U)``.
    n_lps : int
        LPs solved.
    n_prefixes_tested : int
        Mode-sequence prefixes tested.
    n_prefixes_total : int
        All prefixes of length ``1 ... T`` (``sum_k s^k``).
    seconds : float
        Wall time of the enumeration.
    stats : dict
        ``executor`` and ``split_depth`` of the run.

    See Also
    --------
    enumerate_modes : computes it.
    ModeRegion : one region.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import enumerate_modes
    >>> enumeration = enumerate_modes(get_example("powertrain3").build(), 3)
    >>> enumeration.T, enumeration.n, enumeration.m, len(enumeration.regions)
    (3, 3, 1, 16)
    >>> enumeration.n_lps                              # LPs that proved a prefix feasible or not
    33
    """

    system: PWASystem
    T: int
    regions: tuple[ModeRegion, ...]
    scale: np.ndarray
    centre: np.ndarray
    n_lps: int
    n_prefixes_tested: int
    n_prefixes_total: int
    seconds: float
    stats: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return self.system.n

    @property
    def m(self) -> int:
        return self.system.m

    @property
    def n_lps_avoided(self) -> int:
        """LPs saved by pruning: prefixes never tested because an ancestor was empty."""
        return self.n_prefixes_total - self.n_prefixes_tested


def horizon_scaling(system: PWASystem, T: int, copies_of_x: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Half-widths and centres of ``(x, [x_hat,] U)``: state bounds per state copy, input bounds per step."""
    half, centre = system.scales()
    n = system.n
    sx, cx = half[:n], centre[:n]
    su, cu = half[n:], centre[n:]
    scale = np.concatenate([np.tile(sx, copies_of_x), np.tile(su, T)])
    ctr = np.concatenate([np.tile(cx, copies_of_x), np.tile(cu, T)])
    return scale, ctr


def check_horizon(system: PWASystem, T: int) -> None:
    """Validate ``T``: a positive integer satisfying the necessary condition ``T p >= n`` (eq. 8)."""
    if not isinstance(T, (int, np.integer)) or T < 1:
        raise ModelError("horizon T", "a positive integer", repr(T))
    if T * system.p < system.n:
        raise ModelError(
            "horizon T",
            f"T p >= n (eq. 8 of paper 002): T >= {int(np.ceil(system.n / system.p))} for n = {system.n}, p = {system.p}",
            f"T = {T}: no state can be observable in T steps",
        )


#: Measured pair LPs of Algorithm 3.1 per ``N ** 1.5`` regions (models (16) and (17), T = 7-10:
#: 1.9-2.1): the cost model of :func:`predict_analysis_cost`.
PAIR_LPS_PER_REGION_POWER: float = 2.1

#: Seconds per pair LP measured here (models (16) and (17), T = 8-10), for the message only.
SECONDS_PER_PAIR_LP: float = 4e-4


def counted_exactly(system: PWASystem, T: int) -> bool:
    """Whether :func:`predict_analysis_cost` counts the regions at ``T`` itself (no extrapolation):
    ``T`` is at most the smallest horizon of eq. (8) plus two."""
    check_horizon(system, T)
    return T <= int(np.ceil(system.n / system.p)) + 2


def predict_analysis_cost(system: PWASystem, T: int, *, enumeration: ModeEnumeration | None = None) -> dict:
    """The predicted size of Algorithm 3.1 at horizon ``T``, before running it.

    The regions (feasible mode sequences) are counted by the enumeration at the two smallest
    horizons that satisfy eq. (8) plus one and two (a few hundred LPs), and extrapolated
    geometrically with the ratio of the two counts (model (16): 1.94-1.98 per step of T, model
    (17): 1.84-1.90); the pair LPs are ``PAIR_LPS_PER_REGION_POWER * N ** 1.5``, the relation
    measured on models (16) and (17).  At those small horizons themselves the count is exact
    (:func:`counted_exactly`), and ``enumeration``, the enumeration at ``T`` when the caller
    already has it, is counted instead of enumerating again.

    Returns
    -------
    dict
        ``regions``, ``pair_lps``, ``seconds`` (at :data:`SECONDS_PER_PAIR_LP`), ``growth`` (the
        ratio per step of ``T``) and ``basis`` (the horizons counted).
    """
    t_min = int(np.ceil(system.n / system.p))
    t1, t2 = t_min + 1, t_min + 2
    if counted_exactly(system, T):
        if enumeration is not None and (enumeration.system is not system or enumeration.T != T):
            raise ModelError("enumeration", f"the enumeration of this system at T = {T}",
                             f"one at T = {enumeration.T}" if enumeration.system is system else "another system's")
        n_t = len((enumeration if enumeration is not None else enumerate_modes(system, T)).regions)
        growth, basis = None, [T]
    else:
        n1, n2 = len(enumerate_modes(system, t1).regions), len(enumerate_modes(system, t2).regions)
        growth = max(n2 / max(n1, 1), 1.0)
        n_t = n2 * growth ** (T - t2)
        basis = [t1, t2]
    pair_lps = PAIR_LPS_PER_REGION_POWER * n_t ** 1.5
    return {"regions": float(n_t), "pair_lps": float(pair_lps), "seconds": float(pair_lps * SECONDS_PER_PAIR_LP),
            "growth": growth, "basis": basis}


def resolve_pair_lp_budget(max_pair_lps: int | None) -> int:
    """``max_pair_lps`` checked (a positive integer), or the active budget when ``None``."""
    from ..limits import pair_lp_budget

    budget = pair_lp_budget() if max_pair_lps is None else max_pair_lps
    if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 1:
        raise ModelError("max_pair_lps", "a positive number of LPs", repr(budget))
    return int(budget)


def check_analysis_budget(system: PWASystem, T: int, max_pair_lps: int | None, *,
                          enumeration: ModeEnumeration | None = None) -> dict | None:
    """Refuse a horizon whose predicted pair LPs exceed ``max_pair_lps`` (``None``: the active
    budget, :data:`~hybobs_opt.limits.MAX_PREDICTED_PAIR_LPS` unless raised); returns the prediction
    (``enumeration``: as in :func:`predict_analysis_cost`)."""
    from ..limits import MAX_PREDICTED_PAIR_LPS

    budget = resolve_pair_lp_budget(max_pair_lps)
    cost = predict_analysis_cost(system, T, enumeration=enumeration)
    if cost["pair_lps"] > budget:
        hours = cost["seconds"] / 3600.0
        raise ModelError("max_pair_lps", f"a horizon whose predicted pair LPs fit the budget of {int(budget):,} "
                         f"(hybobs_opt.limits.MAX_PREDICTED_PAIR_LPS = {MAX_PREDICTED_PAIR_LPS:,}; raise it to run "
                         "this one anyway)",
                         f"T = {T}: about {cost['regions']:.3g} regions and {cost['pair_lps']:.3g} pair LPs predicted "
                         f"(about {hours:.3g} h), from the regions counted at T = {cost['basis']}")
    return cost


#: Below this many mode sequences (``n_modes ** T``) the tree is enumerated in the calling process
#: whatever the executor: model (16) at T = 5 (243 sequences) takes about 0.1 s, less than starting
#: worker processes.
PARALLEL_MIN_SEQUENCES = 500


class _Node:
    """A prefix of the tree: affine state map, accumulated constraint rows and output rows."""

    __slots__ = ("seq", "Phi", "Gamma", "phi", "H", "h", "C", "D", "f", "prev")

    def __init__(self, seq, Phi, Gamma, phi, H, h, C, D, f, prev=None):
        self.seq, self.Phi, self.Gamma, self.phi = seq, Phi, Gamma, phi
        self.H, self.h, self.C, self.D, self.f = H, h, C, D, f
        self.prev = prev  # (Phi, Gamma, phi) of the state before the last step

    def region(self, slack: float) -> "ModeRegion":
        Pl, Gl, pl = self.prev
        return ModeRegion(self.seq, self.H, self.h, self.C, self.D, self.f, self.Phi, self.Gamma, self.phi, float(slack), Pl, Gl, pl)


def _root(system: PWASystem, T: int) -> _Node:
    n, m = system.n, system.m
    return _Node((), np.eye(n), np.zeros((n, T * m)), np.zeros(n), np.zeros((0, n + T * m)), np.zeros(0),
                 np.zeros((0, n)), np.zeros((0, T * m)), np.zeros(0))


def _step_rows(node: _Node, Ek: np.ndarray, rows_A: np.ndarray, rows_b: np.ndarray, n: int, box=None):
    """Rows ``rows_A [x_k; u_k] <= rows_b`` at the step after ``node`` written over ``(x, U)``.

    ``x_k`` is the node's state map and ``u_k = Ek U``.  With ``box = (scale, centre)``, rows that
    cannot be active anywhere in the box ``X x U^T`` are implied by it and dropped (interval
    arithmetic, exact); the box's own rows reach their bound and are kept.
    """
    Ax, Au = rows_A[:, :n], rows_A[:, n:]
    newH = np.hstack([mm(Ax, node.Phi), mm(Ax, node.Gamma) + mm(Au, Ek)])
    newh = rows_b - mm(Ax, node.phi)
    if box is not None:
        scale, centre = box
        reach = mm(newH, centre) + mm(np.abs(newH), scale)
        keep = reach > newh - BOX_IMPLIED_RTOL * (1.0 + np.abs(newh))
        newH, newh = newH[keep], newh[keep]
    return newH, newh


def _child(system: PWASystem, T: int, node: _Node, i: int, domain_rows, box=None) -> _Node:
    """Extend ``node`` by mode ``i`` at step ``k = len(node.seq)``."""
    n, m = system.n, system.m
    k = len(node.seq)
    mode = system.modes[i]
    Ek = np.zeros((m, T * m))
    Ek[:, k * m : (k + 1) * m] = np.eye(m)
    newH, newh = _step_rows(node, Ek, np.vstack([mode.guard.A, domain_rows[0]]),
                            np.concatenate([mode.guard.b, domain_rows[1]]), n, box)
    C = np.vstack([node.C, mm(mode.C, node.Phi)])
    D = np.vstack([node.D, mm(mode.C, node.Gamma) + mm(mode.D, Ek)])
    f = np.concatenate([node.f, mm(mode.C, node.phi) + mode.c])
    Phi = mm(mode.A, node.Phi)
    Gamma = mm(mode.A, node.Gamma) + mm(mode.B, Ek)
    phi = mm(mode.A, node.phi) + mode.a
    return _Node(node.seq + (i,), Phi, Gamma, phi, np.vstack([node.H, newH]), np.concatenate([node.h, newh]), C, D, f,
                 (node.Phi, node.Gamma, node.phi))


def _slack(node: _Node, scale: np.ndarray, centre: np.ndarray) -> float:
    G = node.H * scale[None, :]
    g = node.h - mm(node.H, centre)
    res = max_slack(G, g, radius_bound=np.sqrt(scale.size), threshold=REGION_SLACK_TOL,
                    problem=f"region of mode prefix {node.seq}")
    return res.lower if res.lower > REGION_SLACK_TOL else res.upper


def _expand(system: PWASystem, T: int, node: _Node, scale, centre, domain_rows, out: list, counts: list) -> None:
    """Depth-first expansion in lexicographic order (so every executor returns the same order)."""
    for i in range(system.n_modes):
        child = _child(system, T, node, i, domain_rows, (scale, centre))
        counts[0] += 1
        slack = _slack(child, scale, centre)
        if slack <= REGION_SLACK_TOL:
            continue
        if len(child.seq) == T:
            out.append(child.region(slack))
        else:
            _expand(system, T, child, scale, centre, domain_rows, out, counts)


def _prefix_node(system: PWASystem, T: int, prefix: tuple[int, ...], domain_rows) -> _Node:
    node = _root(system, T)
    for i in prefix:
        node = _child(system, T, node, i, domain_rows, horizon_scaling(system, T))
    return node


def enumerate_subtree(system: PWASystem, T: int, prefix: tuple[int, ...]) -> tuple[list[ModeRegion], int, int]:
    """Enumerate the regions below ``prefix`` (a feasible prefix); returns (regions, n_tested, n_lps)."""
    scale, centre = horizon_scaling(system, T)
    domain = system.domain
    domain_rows = (domain.A, domain.b)
    out: list[ModeRegion] = []
    counts = [0]
    with counting_lps() as lps:
        node = _prefix_node(system, T, prefix, domain_rows)
        if len(prefix) == T:
            slack = _slack(node, scale, centre)
            counts[0] += 1
            if slack > REGION_SLACK_TOL:
                out.append(node.region(slack))
        else:
            _expand(system, T, node, scale, centre, domain_rows, out, counts)
    return out, counts[0], lps.total


def _feasible_prefixes(system: PWASystem, T: int, depth: int) -> tuple[list[tuple[int, ...]], int]:
    """Feasible prefixes of length ``depth`` (breadth-first, lexicographic), and the number tested."""
    scale, centre = horizon_scaling(system, T)
    domain_rows = (system.domain.A, system.domain.b)
    level = [_root(system, T)]
    tested = 0
    for _ in range(depth):
        nxt = []
        for node in level:
            for i in range(system.n_modes):
                child = _child(system, T, node, i, domain_rows, (scale, centre))
                tested += 1
                if _slack(child, scale, centre) > REGION_SLACK_TOL:
                    nxt.append(child)
        level = nxt
    return [node.seq for node in level], tested


def _subtree_task(args):
    system, T, prefix = args
    return enumerate_subtree(system, T, prefix)


def enumerate_modes(
    system: PWASystem,
    T: int,
    *,
    executor=None,
    progress: Callable[[int, int], None] | None = None,
) -> ModeEnumeration:
    """Enumerate the regions ``P_i`` of eq. (4) of paper 002 for horizon ``T``.

    Parameters
    ----------
    system : PWASystem
    T : int
        Horizon (must satisfy ``T p >= n``, eq. 8).
    executor : Executor, optional
        Where the subtrees run (:mod:`hybobs_opt.executor`); serial by default.  Every executor
        returns the same regions in the same (lexicographic) order.
    progress : callable, optional
        ``progress(done, total)`` over the subtrees below the feasible prefixes (of length 2,
        or more with parallel workers; the whole tree is one subtree when ``T <= 2``).

    Returns
    -------
    ModeEnumeration

    See Also
    --------
    ModeEnumeration : what it returns.
    analyse_observability : runs it first.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import enumerate_modes
    >>> enumeration = enumerate_modes(get_example("powertrain3").build(), 3)
    >>> len(enumeration.regions), enumeration.regions[0].sequence    # 16 feasible sequences of 3 modes
    (16, (0, 0, 0))
    >>> enumeration.n_prefixes_tested, enumeration.n_prefixes_total
    (33, 39)
    """
    from ..executor import resolve_executor

    check_horizon(system, T)
    executor = resolve_executor(executor)
    t0 = time.perf_counter()
    depth = 0
    parallel = executor.n_workers > 1 and T > 2 and system.n_modes ** T > PARALLEL_MIN_SEQUENCES
    if parallel:
        # Split into enough subtrees to keep every worker busy.
        depth = 1
        while depth < T - 1 and system.n_modes ** depth < 4 * executor.n_workers:
            depth += 1
    elif progress is not None and T > 2:
        depth = 2  # a few subtrees to report progress over (the same tests, the same order)
    with counting_lps() as lps_here:
        prefixes, tested = _feasible_prefixes(system, T, depth) if depth else ([()], 0)
    if progress is not None:
        progress(0, len(prefixes))
    results = executor.map(_subtree_task, [(system, T, p) for p in prefixes], progress=progress)
    regions: list[ModeRegion] = []
    n_lps = lps_here.total
    for regs, n_tested, lps in results:
        regions.extend(regs)
        tested += n_tested
        n_lps += lps
    total = sum(system.n_modes ** k for k in range(1, T + 1))
    scale, centre = horizon_scaling(system, T)
    return ModeEnumeration(system, T, tuple(regions), scale, centre, n_lps, tested, total, time.perf_counter() - t0,
                           {"executor": executor.name if parallel else "serial", "split_depth": depth})


@dataclass(frozen=True, eq=False)
class PrefixSuperset:
    """A polytope over ``(x, U)`` containing every region ``P_i`` whose mode sequence starts with ``prefix``.

    ``H [x; U] <= h`` are the rows of the prefix's modes (the very rows its regions carry), the
    domain at step ``len(prefix)`` and the input box at the later steps; ``C, D, f`` are the
    first output rows shared bit for bit by all those regions (the later outputs depend on the
    modes left free, so they are dropped).  A pair set built from two such supersets contains the
    pair sets ``R_ij`` of all their regions (:mod:`~hybobs_opt.regions.pair_groups`).
    """

    prefix: tuple[int, ...]
    H: np.ndarray
    h: np.ndarray
    C: np.ndarray
    D: np.ndarray
    f: np.ndarray


def _shared_output_rows(regions, index: np.ndarray, first: dict, depth: int) -> int | None:
    """``depth + 1`` when every region shares its output rows ``0 .. depth`` bit for bit with the
    first region below its prefix (``index``, ``first``), ``depth`` when only the rows before
    ``depth``, ``None`` when not even those (compared all at once when the regions' output maps
    have one shape, as an enumeration's always do)."""
    ref = np.array([first[int(a)] for a in index], dtype=int)
    shapes = {(r.C.shape, r.D.shape, r.f.shape) for r in regions}
    if len(shapes) == 1:
        maps = [np.stack([getattr(r, name) for r in regions]) for name in ("C", "D", "f")]

        def same(rows) -> bool:
            return all(bool(np.all(M[:, rows] == M[ref][:, rows])) for M in maps)

        if not same(slice(0, depth)):
            return None
        return depth + 1 if same(depth) else depth
    q = depth + 1
    for k, reg in enumerate(regions):
        r = regions[ref[k]]
        if not (np.array_equal(reg.C[:depth], r.C[:depth]) and np.array_equal(reg.D[:depth], r.D[:depth])
                and np.array_equal(reg.f[:depth], r.f[:depth])):
            return None
        if q > depth and not (np.array_equal(reg.C[depth], r.C[depth]) and np.array_equal(reg.D[depth], r.D[depth])
                              and reg.f[depth] == r.f[depth]):
            q = depth
    return q


def prefix_supersets(enum: ModeEnumeration, depth: int, nodes: dict | None = None) -> tuple[list[PrefixSuperset], np.ndarray] | None:
    """The :class:`PrefixSuperset` of every distinct prefix of length ``depth`` of the regions' sequences.

    Returns ``(supersets, index)`` with ``index[k]`` the superset of region ``k``, or ``None``
    when the regions below one prefix do not share their first ``depth`` output rows (they
    always do when built by :func:`enumerate_modes`).  The output rows kept are ``depth + 1``
    when every region shares row ``depth`` with the others below its prefix (the modes' output
    maps agree, as in the powertrains), else ``depth``.  ``nodes``: a dict kept between the
    calls for one enumeration at several depths, where the prefixes' rows are built once.
    """
    system, T = enum.system, enum.T
    if not 1 <= depth < T:
        raise ModelError("depth", f"an integer in [1, {T - 1}]", repr(depth))
    n, m = system.n, system.m
    scale, centre = enum.scale, enum.centre
    domain_rows = (system.domain.A, system.domain.b)
    prefixes: dict[tuple[int, ...], int] = {}
    index = np.empty(len(enum.regions), dtype=int)
    for k, reg in enumerate(enum.regions):
        index[k] = prefixes.setdefault(tuple(reg.sequence[:depth]), len(prefixes))
    first = {}
    for k in range(len(enum.regions)):
        first.setdefault(int(index[k]), k)
    q = _shared_output_rows(enum.regions, index, first, depth)
    if q is None:
        return None
    if nodes is None:
        nodes = {}
    nodes.setdefault((), _root(system, T))

    def node_of(prefix):
        if prefix not in nodes:
            nodes[prefix] = _child(system, T, node_of(prefix[:-1]), prefix[-1], domain_rows, (scale, centre))
        return nodes[prefix]

    box_rows = np.vstack([np.eye(m), -np.eye(m)])
    out = []
    for prefix, a in prefixes.items():
        node = node_of(prefix)
        ref = enum.regions[first[a]]
        Hs, hs = [node.H], [node.h]
        Ek = np.zeros((m, T * m))
        Ek[:, depth * m:(depth + 1) * m] = np.eye(m)
        # the domain at step `depth` (the state there is fixed by the prefix), as _child adds it
        newH, newh = _step_rows(node, Ek, domain_rows[0], domain_rows[1], n, (scale, centre))
        Hs.append(newH)
        hs.append(newh)
        for k in range(depth + 1, T):  # later inputs: their box (every region below has it)
            rows = np.zeros((2 * m, n + T * m))
            rows[:, n + k * m:n + (k + 1) * m] = box_rows
            cu, su = centre[n + k * m:n + (k + 1) * m], scale[n + k * m:n + (k + 1) * m]
            Hs.append(rows)
            hs.append(np.concatenate([cu + su, su - cu]))
        out.append(PrefixSuperset(prefix, np.vstack(Hs), np.concatenate(hs), ref.C[:q], ref.D[:q], ref.f[:q]))
    return out, index
