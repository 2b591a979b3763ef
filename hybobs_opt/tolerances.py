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

#: A constraint row whose norm is below this is treated as zero (the constraint no longer depends
#: on the variables: it holds or fails by its right-hand side alone).  Callers pass rows that were
#: unit-norm in scaled coordinates before any restriction to a subspace, so this is relative.
ZERO_ROW_TOL: float = 1e-10

#: Relative singular-value threshold for rank tests (``s_min / s_max``) in scaled coordinates.
RANK_RTOL: float = 1e-12

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

# ---------------------------------------------------------------------- polytope operations
# (projection, redundancy removal, set difference; paper 002, Sections 2-3).  All of these act in
# coordinates scaled so that the set's bounding box is [-1, 1]^d.

#: A row is redundant when its maximum over the other rows exceeds its right-hand side by at
#: most this, relative to ``1 + |b_i|``.  HiGHS certifies optimality to a primal/dual feasibility
#: of 1e-7, so a smaller value would keep rows whose "non-redundancy" is LP noise; dropping a row
#: that cuts off less than this moves the set by a negligible 1e-7 of its size.
REDUNDANCY_RTOL: float = 1e-7

#: Two unit-norm rows are treated as the same direction (the looser one dropped without an LP)
#: when they round to the same point of a grid of this spacing: they then differ by at most
#: ``sqrt(d) * 1e-10``, which moves the set by far less than REDUNDANCY_RTOL inside the unit box.
#: Near-parallel rows that straddle a grid line are simply left to the LP test.
PARALLEL_ROW_TOL: float = 1e-10

#: Iterative-hull projection: a support point found beyond a facet of the current hull by more
#: than this (target coordinates scaled to the image's bounding box) is added and the hull is
#: rebuilt.  Ten times the LP feasibility tolerance, so LP noise cannot create endless near-
#: duplicate points; the computed projection is exact to this relative accuracy.
PROJECTION_HULL_RTOL: float = 1e-6

#: A cloud of support points (scaled to the unit box) is flat in a direction when its singular
#: value there is below this: the projection then lies in that affine hull (a lower-dimensional
#: set, returned with its equalities as paired inequalities).  Same size as PROJECTION_HULL_RTOL
#: because both compare LP support values in the same scaled coordinates.
AFFINE_HULL_RTOL: float = 1e-6

#: Least-squares residual of ``E z = e`` (scaled coordinates), relative to ``1 + |e|``, above
#: which the equalities are declared inconsistent.  Well above the rank-truncation noise
#: (RANK_RTOL times the largest singular value times ``|z|``) and far below any real conflict.
EQUALITY_CONSISTENCY_RTOL: float = 1e-7

#: A constraint row is implied by the box X x U^T (and dropped) when its largest value over the box
#: stays below its bound by this relative margin; rows that reach the bound are kept.
BOX_IMPLIED_RTOL: float = 1e-12

#: Rows whose slack at DAQP's point is within this (scaled units) of DAQP's slack variable are
#: treated as active when the dual multipliers are refined.  DAQP's points violate rows by up to
#: about 1e-6 here; extra rows only give NNLS more freedom, the bound stays valid for any choice.
NEAR_ACTIVE_TOL: float = 1e-5

#: Redundancy removal by ray shooting from an interior point: the first row crossed is a facet
#: only if the next row is crossed later by more than this fraction of the distance; closer
#: crossings (a ray through a vertex or edge, up to rounding) prove nothing and an LP decides.
RAY_TIE_RTOL: float = 1e-9

#: Lookup observer (paper 002, Algorithm 4.1): a region test [x_i; U] in P_i passes when every
#: row (unit-norm in scaled coordinates) is violated by at most this; far above the rounding of
#: C_i^+ (about 1e-12 relative) and far below any real excursion out of a region.
LOOKUP_MEMBERSHIP_TOL: float = 1e-7

#: Lookup observer: the output equality C_i x_i = Y - D_i U - f_i of eq. (12) holds when its
#: residual is below this times max(1, |Y|_inf).  Noise-free data give about 1e-13; raise it
#: (output_rtol=...) for noisy measurements.
LOOKUP_OUTPUT_RTOL: float = 1e-8

#: Lookup observer: two candidates of chi are the same state when they differ by less than this
#: in coordinates scaled by the state bounds (a state on the common boundary of two regions).
LOOKUP_SAME_STATE_TOL: float = 1e-6

#: Lookup observer: a candidate must lie *strictly* inside its region P_i, by this margin (rows
#: unit-norm in scaled coordinates).  The paper's regions are not closed: when the true shaft
#: enters the backlash, the data force the contact region's candidate exactly onto the guard
#: boundary, which belongs to the backlash sequence.  States closer than this to a boundary are
#: flagged unobservable (conservative), never wrongly reconstructed.
LOOKUP_INTERIOR_MARGIN: float = 1e-9
