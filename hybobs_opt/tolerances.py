"""Named numerical tolerances.

Every tolerance used by the toolbox is defined here, with the reason for its size, so that no
bare literal decides a geometric or numerical question somewhere deep in the code.  Tolerances
on geometry are *relative*: they apply in coordinates normalised by the state and input bounds
(DESIGN.md, "Scale before you solve").
"""

#: Slack allowed when testing ``A z <= b`` for a point, relative to ``1 + |b|`` row-wise.
MEMBERSHIP_RTOL: float = 1e-9

#: A polytope is full-dimensional when its Chebyshev radius, in coordinates scaled to the unit
#: box of its bounding box, exceeds this value.
FULL_DIMENSION_RTOL: float = 1e-7

#: Row-normalised constraint coefficients below this are treated as zero (degenerate rows).
ZERO_ROW_TOL: float = 1e-12

#: Relative singular-value threshold for rank tests (``s_min / s_max``) in scaled coordinates.
RANK_RTOL: float = 1e-9

#: Relative tolerance used when checking that two affine maps (mode dynamics) are equal.
MATRIX_EQUAL_RTOL: float = 1e-12

#: A user-supplied derivative of a scalar function (paper 004, eq. 3) must match CasADi's automatic
#: derivative to this tolerance relative to ``1 + max |f'|`` on the operating box: both are exact
#: up to rounding, so any real disagreement is a wrong formula, not noise.
DERIVATIVE_CHECK_RTOL: float = 1e-8

#: Relative / absolute tolerances of the adaptive ODE solver of the nonlinear simulator: tight
#: enough that the sampled trajectory is exact for the physics checks of the examples (turn angles
#: to 1e-6 rad), loose enough to keep a 30 s vehicle scenario well under a second.
NONLINEAR_ODE_RTOL: float = 1e-10
NONLINEAR_ODE_ATOL: float = 1e-10

#: Cap on the slack variable of max-slack LPs (in scaled coordinates a set inside the unit box has
#: Chebyshev radius <= 1, so the cap never binds for the sets of interest and keeps LPs bounded).
SLACK_CAP: float = 1.0

#: A region (or a pair set R_ij) counts as non-empty and full-dimensional when its Chebyshev
#: radius in coordinates scaled to [-1, 1] by the state and input bounds exceeds this.  Regions
#: thinner than 1e-6 of the operating range are numerically indistinguishable from boundaries.
REGION_SLACK_TOL: float = 1e-6
