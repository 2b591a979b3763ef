"""The pre-filter boxes of point queries (``ObservabilityAnalysis._x_boxes``) are outer boxes."""

import numpy as np


def test_point_query_boxes_contain_the_projections():
    """The pre-filter boxes of ``ObservabilityAnalysis.regions_containing`` (certified DAQP bounds)
    contain every region's projection on x: each side checked against HiGHS at 1e-10 tolerances
    in the same scaled coordinates (model 16, T = 5)."""
    from scipy.optimize import linprog

    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.studies import get_example

    a = analyse_observability(get_example("powertrain3").build(), 5)
    boxes = a._x_boxes()
    sc, ce, n = a.enumeration.scale, a.enumeration.centre, a.system.n
    widening = []
    for k, reg in enumerate(a.regions):
        G, g = reg.H * sc[None, :], reg.h - reg.H @ ce
        for j in range(n):
            for side, sgn in ((1, 1.0), (0, -1.0)):
                c = np.zeros(G.shape[1])
                c[j] = sgn
                r = linprog(-c, A_ub=G, b_ub=g, bounds=(None, None), method="highs",
                            options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
                assert r.status == 0
                exact = ce[j] + sc[j] * sgn * (-r.fun)
                widening.append(sgn * (boxes[k, side, j] - exact) / sc[j])
    assert min(widening) >= -1e-9, min(widening)
    assert np.median(widening) <= 1e-6  # a pre-filter, not the whole box
