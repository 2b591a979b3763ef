"""LP counts are held by the caller (:func:`hybobs_opt.geometry.lp.counting_lps`), and every checked LP
answers with the one result type :class:`~hybobs_opt.geometry.lp.LPResult`."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from hybobs_opt.geometry.lp import LPResult, counting_lps, highs_lp, max_slack, verified_lp
from hybobs_opt.status import Status

BOX = (np.vstack([np.eye(2), -np.eye(2)]), np.array([1.0, 2.0, 3.0, 4.0]))  # -3 <= x1 <= 1, -4 <= x2 <= 2


def test_verified_lp_is_an_lp_result_agreeing_with_scipy():
    A, b = BOX
    c = np.array([1.0, -2.0])
    with counting_lps() as lps:
        ans = verified_lp(c, A, b, problem="box")
    ref = linprog(c, A_ub=A, b_ub=b, bounds=[(None, None)] * 2, method="highs")
    assert isinstance(ans, LPResult) and ans.status == Status.OPTIMAL
    assert np.isclose(ans.objective, ref.fun) and np.allclose(ans.x, ref.x)
    assert ans.duals is not None and np.all(ans.duals >= -1e-12)
    assert (lps.fast, lps.confirmed_by_highs) == ((1, 0) if ans.solver == "daqp" else (0, 1))
    empty = verified_lp(c, np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([-1.0, -1.0]), problem="empty")
    assert isinstance(empty, LPResult) and empty.status == Status.INFEASIBLE and empty.x is None


def test_nested_blocks_add_up_and_a_replaced_fast_lp_counts_once():
    A, b = BOX
    with counting_lps() as outer:
        verified_lp(np.array([1.0, 0.0]), A, b, problem="box")
        with counting_lps() as inner:
            max_slack(A, b, radius_bound=10.0, threshold=0.0)
            verified_lp(np.array([0.0, 1.0]), A, b, problem="box")
        assert inner.total == 2
        assert outer.total == 3  # the inner block's LPs count in the outer one too
        before = (outer.fast, outer.confirmed_by_highs)
        highs_lp(np.array([1.0, 1.0]), A, b, problem="box", replaces_fast=True)  # the same LP, now HiGHS's
    assert outer.total == 3  # the replaced LP moved from fast to confirmed: still one LP
    assert (outer.fast, outer.confirmed_by_highs) == (before[0] - 1, before[1] + 1)
    with counting_lps() as separate:
        pass
    assert separate.total == 0  # no process-wide counter leaks into a new block
