"""An exact certificate of the optimum of one MIQP window: branch and bound over mode prefixes.

The MIQP of eq. (10) of paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000) is solved by DAQP's
branch and bound with a proximal term (:class:`~hybobs_opt.mhe.MHEObserver`), whose a-priori
certificate ``gap_bound`` is the proximal term's largest value over the variable bounds.  On noisy
data that bound exceeds the optimum itself (4.7e-4 against optima of 0-2e-4 on model (16) with
output noise 0.01 rad/s), so it certifies nothing.  This module proves a gap that is
meaningful against the optimum: a depth-first branch and bound over the mode sequence, one convex
QP per node, in which

* a node is a prefix ``(q_0, ..., q_{k-1})`` of the mode sequence, and its QP is the window's cost
  restricted to the outputs of the first ``k`` steps (with the disturbance and arrival terms of
  the whole window, and an extension's squares and rows on the variables the prefix fixes) over
  the rows of those steps
  (:meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`).  Every sequence that begins with
  the prefix has a cost at least this QP's minimum: its terms are non-negative and its rows
  include the prefix's;
* the lower bound of a node is proven in numpy from DAQP's point and multipliers by weak duality
  over the variable bounds (:meth:`~hybobs_opt.mhe.window.WindowModel.sequence_qp`), and an
  infeasible prefix is pruned only when DAQP's Farkas multipliers prove it;
* a leaf (a full sequence) gives a feasible point, whose exact cost is an upper bound of the
  optimum;
* a node is pruned when its lower bound is within the allowed gap of the best cost found.

When the search closes every node, the optimum lies between the least lower bound of the closed
nodes and the best cost: ``gap = best - lower <= max(rtol * best, atol)``.  The search stops
(not certified) after ``max_nodes`` QPs, once a wall-clock ``deadline`` has passed (the observer's
``certify_time_budget``), or at the first node QP without a certified answer.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

__all__ = ["SequenceSearch", "leaf_trajectory", "node_qp", "search_sequences"]

#: Node QPs kept per window by :func:`node_qp` (the optimum's search and the uniqueness search
#: of the same window ask for the same prefixes; a few hundred per window at T = 10).
NODE_CACHE_SIZE = 20000


def node_qp(model, seq: tuple, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray):
    """The QP of the mode prefix ``seq`` of one window with its proven lower bound:
    ``(problem, solved)``, ``problem`` of :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`
    and ``solved`` of :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_qp` with ``bound`` and
    ``multipliers`` (``(theta, lower, lam)``, ``(None, inf, None)`` or ``None``).

    Kept on ``model`` for the window's data (inputs, outputs, prior, arrival weight and extension
    parameters, compared byte for byte): the certified optimum's search and the uniqueness search of the same
    window solve each prefix once.
    """
    key = (U.tobytes(), Y.tobytes(), np.asarray(xbar, dtype=float).tobytes(),
           None if model.params is None else model.params.tobytes(), None if model.Wa is None else model.Wa.tobytes())
    held = model.__dict__.get("_node_cache")
    if held is None or held[0] != key or len(held[1]) >= NODE_CACHE_SIZE:
        held = (key, {})
        model.__dict__["_node_cache"] = held
    cache = held[1]
    hit = cache.get(seq)
    if hit is None:
        problem = model.sequence_problem(seq, U, Y, xbar)
        hit = (problem, model.sequence_qp(problem, None, bound=True, multipliers=True))
        cache[seq] = hit
    return hit


@dataclass(frozen=True)
class SequenceSearch:
    """Result of :func:`search_sequences`.

    Parameters
    ----------
    certified : bool
        Every node closed and ``cost - lower_bound <= max(rtol * cost, atol)``.
    modes : (T,) int array or None
        The best mode sequence found (the incumbent's when none beat it).
    x0 : (n,) array or None
        Window-start state of the best leaf the search solved (``None`` when the incumbent was
        not beaten: it stays the caller's).
    w : (T - 1, n) array or None
        Its disturbances (zeros without disturbance terms).
    cost : float
        Exact cost of the best sequence found (an upper bound of the optimum; ``inf`` if none).
    lower_bound : float
        Proven lower bound of the optimum (the least bound of the closed nodes).
    improved : bool
        Whether the search found a sequence cheaper than the incumbent.
    nodes : int
        Node QPs solved.
    seconds : float
        Wall time.
    reason : str
        Why the search is not certified (empty when it is).
    exhaustive : bool
        Every node was closed (the search did not stop at its budget or at a node QP without a
        certified answer); with no finite ``cost`` it proves that no mode sequence is feasible.

    See Also
    --------
    search_sequences : Returns one.
    MHEObserver : Certifies windows with it when the solver cannot.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import search_sequences
    >>> obs = MHEObserver(plant, 3)
    >>> found = search_sequences(obs.model, U[:3], truth.y[:3], obs.model.cx, rtol=1e-9, atol=1e-12,
    ...                          max_nodes=1000)
    >>> found.certified, found.modes, bool(found.gap <= 1e-6)
    (True, array([2, 2, 2]), True)
    """

    certified: bool
    modes: np.ndarray | None
    x0: np.ndarray | None
    w: np.ndarray | None
    cost: float
    lower_bound: float
    improved: bool
    nodes: int
    seconds: float
    reason: str = ""
    exhaustive: bool = True

    @property
    def gap(self) -> float:
        """``cost - lower_bound`` (``inf`` without a finite cost)."""
        return float(self.cost - self.lower_bound) if np.isfinite(self.cost) else float("inf")


def leaf_trajectory(model, modes, theta: np.ndarray, problem: tuple, U: np.ndarray, Y: np.ndarray,
                    xbar: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The window trajectory of a full mode sequence's QP point ``theta`` (scaled), in model units:
    ``(x0, W, states, cost)``, the cost of eq. (10) recomputed in numpy (an upper bound of the
    sequence's optimum)."""
    T, n = model.T, model.n
    x0 = model.cx + model.hx * theta[:n]
    W = (theta[n:].reshape(T - 1, n) * model.hx) if problem[4] else np.zeros((max(T - 1, 0), n))
    modes = np.asarray(modes, dtype=int)
    states = model.trajectory(x0, modes, U, W)
    return x0, W, states, model.cost(states, modes, U, Y, W, xbar)


def search_sequences(model, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, incumbent: tuple | None = None, *,
                     rtol: float, atol: float, max_nodes: int, deadline: float | None = None,
                     time_budget: float | None = None) -> SequenceSearch:
    """Certify (or find) the optimum of one window of eq. (10), norm 2, by branch and bound over mode prefixes.

    Parameters
    ----------
    model : WindowModel
        The window's model, weights and cost (:class:`~hybobs_opt.mhe.window.WindowModel`, norm 2).
    U : (T, m) array
        The window's inputs.
    Y : (T, p) array
        The window's outputs.
    xbar : (n,) array
        The arrival-cost prior (the observer's ``x_start``).
    incumbent : tuple, optional
        ``(modes, cost)`` of a verified trajectory of the window (the first upper bound).
    rtol, atol : float
        The gap to prove: ``cost - lower <= max(rtol * cost, atol)`` (original cost units).
    max_nodes : int
        Node QPs allowed before the search gives up (not certified).
    deadline : float, optional
        ``time.perf_counter()`` value after which no further node QP is solved (not certified,
        the reason names the budget).  ``None``: no time limit.
    time_budget : float, optional
        The budget in seconds the deadline stands for (for the reason only).

    Returns
    -------
    SequenceSearch

    See Also
    --------
    SequenceSearch : What it returns.
    MHEObserver.solve_window : Solves the same window with the MIQP solver.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import search_sequences
    >>> obs = MHEObserver(plant, 3)
    >>> found = search_sequences(obs.model, U[:3], truth.y[:3], obs.model.cx, rtol=1e-9, atol=1e-12,
    ...                          max_nodes=1000)
    >>> found.certified, found.modes
    (True, array([2, 2, 2]))
    >>> bool(np.allclose(found.x0, truth.x[0], atol=1e-6))
    True
    """
    t0 = time.perf_counter()
    T = model.T
    n_modes = model.system.n_modes
    best_modes = None if incumbent is None else np.asarray(incumbent[0], dtype=int)
    best_cost = np.inf if incumbent is None else float(incumbent[1])
    best_theta, improved = None, False
    closed = np.inf  # least lower bound of the closed nodes
    nodes = 0

    def allowed(cost: float) -> float:
        return max(rtol * cost, atol) if np.isfinite(cost) else 0.0

    def stop(reason: str) -> SequenceSearch:
        return SequenceSearch(False, best_modes, None, None, best_cost, min(closed, best_cost), improved, nodes,
                              time.perf_counter() - t0, reason, exhaustive=False)

    stack: list[tuple[tuple[int, ...], float]] = [((), -np.inf)]
    while stack:
        prefix, bound = stack.pop()
        if bound >= best_cost - allowed(best_cost):
            closed = min(closed, bound)  # an incumbent found since it was pushed prunes it now
            continue
        children = []
        for q in range(n_modes):
            seq = prefix + (q,)
            nodes += 1
            if nodes > max_nodes:
                return stop(f"node budget of {max_nodes} QPs exhausted")
            if deadline is not None and time.perf_counter() > deadline:
                nodes -= 1
                budget = "" if time_budget is None else f" of {time_budget:g} s"
                return stop(f"time budget{budget} (certify_time_budget) exhausted after {nodes} node QPs")
            problem, solved = node_qp(model, seq, U, Y, xbar)
            if solved is None:
                return stop(f"the QP of the mode prefix {seq} has no certified answer")
            theta, lower = solved[:2]
            if theta is None:
                continue  # proven infeasible: no sequence begins with it
            if len(seq) == T:
                x0, W, _, cost = leaf_trajectory(model, seq, theta, problem, U, Y, xbar)
                if cost < best_cost:
                    best_modes, best_cost, best_theta, improved = np.array(seq, dtype=int), cost, (x0, W), True
                if lower < best_cost - allowed(best_cost):
                    # a leaf's bound below the gap to prove would leave the window uncertified:
                    # proven again from more multipliers (Clarabel's, exact KKT solutions of more
                    # active sets), any of which gives a valid bound
                    again = model.sequence_qp(problem, theta, bound=True, robust=True)
                    if again is not None and again[0] is not None:
                        lower = max(lower, again[1])
                closed = min(closed, lower)
            elif lower >= best_cost - allowed(best_cost):
                closed = min(closed, lower)
            else:
                children.append((lower, seq))
        stack.extend((seq, lower) for lower, seq in sorted(children, reverse=True))  # least bound next
    lower = min(closed, best_cost)
    x0, W = (None, None) if best_theta is None or not improved else best_theta
    ok = np.isfinite(best_cost) and best_cost - lower <= allowed(best_cost)
    return SequenceSearch(bool(ok), best_modes, x0, W, best_cost, lower, improved, nodes, time.perf_counter() - t0,
                          "" if ok else ("no feasible mode sequence" if not np.isfinite(best_cost) else
                                         f"gap {best_cost - lower:.3g} above the allowed {allowed(best_cost):.3g}"))
