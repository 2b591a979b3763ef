"""Named numerical tolerances.

A tolerance is a threshold that decides a numerical or geometric question: is a point in a set,
is a matrix rank-deficient, is a solver's answer accurate enough to be used, are two times the
same instant.  Every such threshold of the toolbox is defined here, with the reason for its size,
so that no bare literal decides a question somewhere deep in the code.  Values a user could
reasonably choose instead (horizons, budgets, default bounds, grid sizes) are in
:mod:`hybobs_opt.defaults`.

Tolerances on geometry are *relative*: they apply in coordinates normalised by the state and
input bounds (DESIGN.md, "Scale before you solve").  The sections below group the tolerances by
what they decide.
"""

# ====================================================================== geometry: membership, dimension, emptiness
# Constraint rows are unit-norm and coordinates scaled to [-1, 1] by the state and input bounds
# (or by a set's bounding box), so these are relative.

#: Slack allowed when testing ``A z <= b`` for a point, relative to ``1 + |b|`` row-wise.
MEMBERSHIP_RTOL: float = 1e-9

#: A polytope is full-dimensional when its Chebyshev radius, in coordinates scaled to the unit
#: box of its bounding box, exceeds this value.
FULL_DIMENSION_RTOL: float = 1e-7

#: Relative margin by which a certified bound of the slack LP must clear ``FULL_DIMENSION_RTOL`` for
#: the partition proof of a PWA system's guards to decide a piece's interior from it (the bounds are
#: proofs; the margin keeps a DAQP answer that differs in its last digits between machines from
#: changing which path decides).  Inside the margin the Chebyshev-ball path decides.
PARTITION_INTERIOR_MARGIN: float = 0.01

#: A constraint row whose norm is below this is treated as zero (the constraint no longer depends
#: on the variables: it holds or fails by its right-hand side alone).  Callers pass rows that were
#: unit-norm in scaled coordinates before any restriction to a subspace, so this is relative.
ZERO_ROW_TOL: float = 1e-10

#: Cap on the slack variable of max-slack LPs (in scaled coordinates a set inside the unit box has
#: Chebyshev radius <= 1, so the cap never binds for the sets of interest and keeps LPs bounded).
SLACK_CAP: float = 1.0

#: A region (or a pair set R_ij) counts as non-empty and full-dimensional when its Chebyshev
#: radius in coordinates scaled to [-1, 1] by the state and input bounds exceeds this.  Regions
#: thinner than 1e-6 of the operating range are numerically indistinguishable from boundaries.
REGION_SLACK_TOL: float = 1e-6

#: A closed set ``{G v <= g}`` (unit rows, scaled) counts as non-empty when relaxing its rows by
#: this much makes it feasible.  It is the accuracy of the LPs themselves, not a geometric
#: tolerance: pair sets that only touch (a shared guard face) are exactly feasible, and DAQP's
#: proximal solves return their points feasible to about 1e-8 (HiGHS's primal tolerance is
#: 1e-7); a tighter 1e-9 leaves about a quarter of the touching pair sets of model 16 at T = 7
#: undecided by DAQP's certificate (they go to HiGHS).  Sets that need more relaxation are empty.
CLOSED_SET_TOL: float = 1e-7

#: Two states count as different (a pair set ``R_ij`` holds a state ``x^ != x``) when they are
#: more than this apart in one scaled coordinate.  Ten times REGION_SLACK_TOL: the pair sets are
#: decided to that tolerance, and a pair whose outputs force ``x^ = x`` computes ``x - x^`` to
#: about 1e-13; anything closer than this is the same state for every test of the toolbox.
DISTINCT_STATE_TOL: float = 1e-5

#: A constraint row is implied by the box X x U^T (and dropped) when its largest value over the box
#: stays below its bound by this relative margin; rows that reach the bound are kept.
BOX_IMPLIED_RTOL: float = 1e-12

#: Regions: the thin test of a pair set's projection (Algorithm 3.1, paper 002) skips its
#: two width LPs when a certified Chebyshev ball of radius ``r`` already gives width
#: ``>= 2 r |c| > 2 REGION_SLACK_TOL (1 + BALL_WIDTH_RTOL)``; the relative margin keeps the
#: comparison away from the floating-point rounding of the LPs' own width bound (~1e-15 relative),
#: so the skipped LPs could not have certified the set thin.
BALL_WIDTH_RTOL: float = 1e-6

# ====================================================================== LP answers and their re-checks
# (hybobs_opt.geometry.lp: a solver's point, multipliers and verdicts are used only after numpy
# has checked them against these.)

#: An "optimal" LP point is accepted only if every row ``a'x <= b`` (or ``= b``) holds to
#: ``LP_POINT_RTOL (1 + |b| + |a| |x|)``, i.e. relative to the terms summed in the row.  HiGHS
#: certifies a primal feasibility of 1e-7 on its internally scaled problem; ten times that leaves
#: room for the unscaling, while a point moved by 1e-3 (a corrupted answer) fails by far.
LP_POINT_RTOL: float = 1e-6

#: The multipliers HiGHS returns with an "optimal" point must certify it: of the right sign,
#: stationary and with a zero duality gap, each to this times the size of the terms summed (on
#: the equilibrated LP, where data and variables are of order one).  HiGHS's dual feasibility
#: tolerance is 1e-7 on its own scaling; ten times that leaves room for the unscaling (the same
#: margin as LP_POINT_RTOL).  Relative, not absolute: an absolute residual bound rejects correct
#: answers of large pair LPs.  A point 1e-3 off the optimum
#: along a feasible direction leaves a gap of ~1e-3: far outside.
LP_DUAL_RTOL: float = 1e-6

#: A vertex solved from a basis of an LP's rows (:func:`hybobs_opt.geometry.lp.chebyshev_lp`) is
#: accepted when every row holds to this fraction of its terms and its basis multipliers are
#: non-negative to this fraction of their size; the basis's condition number must be below
#: LP_VERTEX_MAX_COND, so that rounding in the solve (~1e-16 cond <= 1e-10) stays below it.
LP_VERTEX_RTOL: float = 1e-9
LP_VERTEX_MAX_COND: float = 1e6

#: An "infeasible" / "unbounded" verdict of HiGHS is trusted only with a certificate checked in
#: numpy: Farkas multipliers ``y >= 0`` with ``A'y + E'w = 0`` to this times ``|A|'y + |E|'|w|``
#: and ``b'y + e'w < -this * (|b|'y + |e|'|w|)``, or a ray with ``A d <= 0`` to this relative.
#: The auxiliary LPs normalise ``b'y + e'w = -1``, which HiGHS meets to ~1e-9; rounding of the
#: products is ~1e-15 relative; a wrong verdict (a feasible LP) has no such multipliers at all.
LP_CERTIFICATE_RTOL: float = 1e-7

#: Entries below this times their row's largest are ignored by the geometric-mean scaling (they
#: are still in the LP): rows built by products (pair sets restricted to their equality subspace)
#: hold rounding residues of ~1e-16 (measured down to 2.5e-22) where exact arithmetic gives zero,
#: and scaling by such a residue as if it were an entry can push HiGHS's answer 5e-4 off a row.
#: 100 times the rounding level, and below the 1e-12 spread of a row whose states are in units
#: 1e6 and 1e-6.
LP_SCALING_NOISE_RTOL: float = 1e-14

#: Rows whose slack at DAQP's point is within this (scaled units) of DAQP's slack variable are
#: treated as active when the dual multipliers are refined.  DAQP's points violate rows by up to
#: about 1e-6 here; extra rows only give NNLS more freedom, the bound stays valid for any choice.
NEAR_ACTIVE_TOL: float = 1e-5

#: DAQP solves an LP (zero Hessian) by proximal-point iterations.  Its automatic setting
#: (eps_prox = -1e-6) leaves multipliers about 1e-6 off, too loose to certify that two regions
#: that only touch have a Chebyshev slack of 0 (not above REGION_SLACK_TOL): 44 % of the pair
#: LPs of model (17), T = 7 then need an NNLS refinement.  A forced proximal weight of 1e-7
#: gives multipliers that certify 99.5 % of them directly; 1e-10 stalls more often (6 % failed
#: solves) and the answer is certified by numpy either way, so the value only trades speed.
DAQP_EPS_PROX: float = 1e-7

#: A DAQP answer flagged optimal is used only when its point satisfies every row to this times
#: ``1 + |b_k| + |a_k| |x|`` and its multipliers are non-negative to this times their size.
#: DAQP's proximal points violate the (unit-norm, scaled) rows by up to ~1e-6 (NEAR_ACTIVE_TOL);
#: ten times that accepts every clean answer, while a corrupted one (a point moved by 1e-3,
#: negated multipliers) fails by orders of magnitude and goes to HiGHS.
DAQP_POINT_RTOL: float = 1e-5

#: Regions: DAQP's primal tolerance of the last attempt at a Chebyshev LP of a pair set
#: of Algorithm 3.1 before HiGHS (``pair_geometry._slack_lp``, when DAQP's default attempts do not
#: decide).  A face (radius exactly 0) must be told from an empty set at ``-CLOSED_SET_TOL = -1e-7``
#: by the slack *at the point*; DAQP's default (1e-6) leaves rows violated by ~2e-7-5e-7, 1e-11
#: leaves ~1e-10 (model 16 at T = 8; the faces of model 17 at T = 7, where HiGHS's point can sit at
#: slack -3.4e-6).  The bounds stay the numpy-certified ones.
PAIR_LP_PRIMAL_TOL: float = 1e-11

# ====================================================================== decisions near a threshold

#: A decision taken from certified floating-point bounds (a Chebyshev radius against its
#: threshold, a width against ``2 REGION_SLACK_TOL``, ``|x - x^|`` against DISTINCT_STATE_TOL) is
#: taken in floats only when the bound clears the threshold by this much (scaled units, rows of
#: unit norm); inside the band the LP is re-decided in rational arithmetic
#: (:mod:`hybobs_opt.geometry.exact_lp`).  The bounds are rigorous up to the rounding of their own
#: evaluation, about 1e-15 for the data of order one here: a thousand times that.
EXACT_DECISION_MARGIN: float = 1e-12

#: An LP value taken from HiGHS's point (not a certified bound: its rows hold to LP_POINT_RTOL)
#: that lies within this of the caller's threshold is re-decided in rational arithmetic.
HIGHS_DECISION_BAND: float = 1e-6

# ====================================================================== polytope operations
# (projection, redundancy removal, vertices, volume, set difference; paper 002, Sections 2-3).
# All of these act in coordinates scaled so that the set's bounding box is [-1, 1]^d.

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

#: Redundancy removal by ray shooting from an interior point: the first row crossed is a facet
#: only if the next row is crossed later by more than this fraction of the distance; closer
#: crossings (a ray through a vertex or edge, up to rounding) prove nothing and an LP decides.
RAY_TIE_RTOL: float = 1e-9

#: Library answers of vertex enumeration, convex hulls and redundancy removal (pycddlib, qhull:
#: :mod:`hybobs_opt.geometry.vertices`) are checked in coordinates scaled so the vertices' box is
#: [-1, 1]^d, with unit rows.  A returned vertex may violate a row by at most this, relative to
#: ``1 + |b_i|``: both libraries compute vertices by eliminations on such data to about 1e-13, and
#: the value is MEMBERSHIP_RTOL's, so a checked vertex passes every later membership test.
VERTEX_CHECK_RTOL: float = 1e-9

#: A row counts as tight (active) at a vertex when its slack is at most this, relative to
#: ``1 + |b_i|``; it decides which rows define a vertex and which vertices lie on a facet.  Ten
#: times VERTEX_CHECK_RTOL: a vertex may be off by that much in any row it is said to lie on.
VERTEX_TIGHT_RTOL: float = 1e-8

#: The rows tight at a vertex must determine it: their smallest singular value (unit rows,
#: estimated from below by ``1 / ||A_T^-1||_F``) must exceed this.  Below it the tight rows are
#: dependent to FULL_DIMENSION_RTOL's accuracy and the point is not a checkable vertex (the
#: answer goes to the next path); random and structured polytopes have ratios above 1e-4.
VERTEX_RANK_RTOL: float = 1e-7

#: Two vertices closer than this (infinity norm, scaled coordinates) are the same vertex, and the
#: far end of an edge walked from a vertex must land within this of a vertex of the set for the
#: set to count as complete.  REDUNDANCY_RTOL's size: a vertex missed by less moves the set by less
#: than the redundancy test itself can see; walked edges land within about 1e-12 of true vertices.
VERTEX_SAME_RTOL: float = 1e-7

#: A simplex of a convex hull (:mod:`hybobs_opt.geometry._hull_cycle`) is full (its orientation
#: decided by the sign of its determinant) when ``|det|``
#: exceeds this fraction of Hadamard's bound (the product of its vertices' distances to the
#: centroid): rounding changes ``det`` by ~1e-16 d of that bound, far below.
FULL_SIMPLEX_RTOL: float = 1e-9

#: Checking a hull's triangulation by one ray from the centroid: a simplex contains the ray when
#: every barycentric weight of the test point exceeds this, misses it when one is below minus
#: this; a weight in between leaves the candidate undecided (the next one is tried).
HULL_RAY_WEIGHT_MARGIN: float = 1e-6


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

# ====================================================================== rank and linear algebra

#: Relative singular-value threshold for rank tests (``s_min / s_max``) in scaled coordinates.
RANK_RTOL: float = 1e-12

#: Relative tolerance used when checking that two affine maps (mode dynamics) are equal.
MATRIX_EQUAL_RTOL: float = 1e-12

#: Implicit equalities of a face-confined pair set are added only along directions whose singular
#: value (unit rows) exceeds this fraction of the largest: two tight rows with opposite normals
#: differ by rounding (about 1e-8 on model 16 at T = 7) and would otherwise pin a second,
#: spurious direction, making full projections look flat.  Any dimension drop the reduction
#: proposes is then confirmed by a width certificate on the original set.
IMPLICIT_EQUALITY_RANK_RTOL: float = 1e-6

#: Relative orthogonality at which the Jacobi sweeps of the reproducible singular values
#: (:mod:`hybobs_opt.geometry._reproducible`) stop (a pair of columns is rotated while
#: ``|a_p'a_q| > JACOBI_TOL * |a_p| |a_q|``): four units of rounding (``4 * 2^-52``, four times the
#: double-precision machine epsilon), as LAPACK's ``dgesvj``.
JACOBI_TOL: float = 4.0 * 2.0 ** -52

#: Popov-Belevitch-Hautus test of (A_i, C_i) in coordinates scaled by the state bounds (location
#: observer, paper 000): the pair is unobservable when the smallest singular value of
#: [A - lambda I; C] is below this times the largest.  Eigenvalues are computed to ~1e-13
#: relative, so a real loss of rank (an exact zero, e.g. the backlash location of the driveline)
#: sits far below and any observable pair far above.
OBSERVABILITY_RTOL: float = 1e-9

#: PBH test of the impossibility certificates (:mod:`hybobs_opt.lmi.impossibility`):
#: ``sigma_min([J - lambda I; C]) <= PBH_RTOL * (1 + ||J|| + ||C||)`` counts as rank loss.  The
#: Jacobians are evaluated from the model's functions (rounding ~1e-16 relative); a genuine loss of
#: detectability is an exact zero.
PBH_RTOL: float = 1e-8

#: An eigenvalue of a Jacobian with ``Re lambda >= -EIGEN_DECAY_RTOL * (1 + ||J||)`` counts as not
#: decaying (:mod:`hybobs_opt.lmi.impossibility`): a real part that is zero in exact arithmetic
#: computes to rounding of the eigenvalue solver, ~1e-15 relative.
EIGEN_DECAY_RTOL: float = 1e-9

#: Constant-drift observers (paper 003): rank decisions of the sequential deadbeat algorithm
#: (subspace intersections and images), on singular values relative to the largest.  The
#: event-sampled matrices (eqs. 14-15) are products of a few rational numbers of size ~1; a few
#: products deep the rounding is ~1e-14, while a genuine direction of the error subspace has a
#: singular value of the size of the rates' ratios (>= 1e-3).
SEQUENTIAL_RANK_RTOL: float = 1e-9

#: Constant-drift observers: the per-phase linear conditions on a deadbeat gain are consistent
#: when their least-squares residual is below this times ``1 + |right-hand side|``: rounding gives
#: ~1e-14, a real conflict between two periods' conditions is of the size of the gains themselves.
GAIN_CONSISTENCY_RTOL: float = 1e-8

#: Constant-drift observers: a transition matrix of the periodic error system counts as zero
#: (deadbeat reached) when its largest entry is below this times the product of
#: ``max(1, |M_j|_2)`` over the steps: exactly nilpotent products of the paper's matrices leave
#: ~1e-16 relative residues.
DEADBEAT_RTOL: float = 1e-9

#: Constant-drift observers: entrywise positivity of ``A_j - L_j C_j`` and ``L_j C_j``
#: (Remark 4.4) is accepted down to ``-this * max|A_j|``: the paper's gains (20a-b) make some
#: entries exactly zero in exact arithmetic, which rounds to +-1e-17.
POSITIVITY_RTOL: float = 1e-12

#: Sliding-mode observers (paper 001, canonical form (4)): two observability coordinate maps
#: ``C A_q^k`` (or offsets, or the ``alpha_q`` of two locations) are the same when they differ by
#: less than this relative to their largest entry.  They are products of the model's own numbers
#: (Example 3: exact multiples of 100/7), so rounding leaves ~1e-15; a genuine difference between
#: locations is many orders larger.
CANONICAL_FORM_RTOL: float = 1e-9

# ====================================================================== checks of a model's functions and structure

#: A user-supplied derivative of a scalar function (paper 004, eq. 3) must match CasADi's automatic
#: derivative to this tolerance relative to ``1 + max |f'|`` on the operating box: both are exact
#: up to rounding, so any real disagreement is a wrong formula, not noise.
DERIVATIVE_CHECK_RTOL: float = 1e-8

#: A callable flow is in the triangular form (4) of paper 001 when ``x_k' - x_{k+1}`` (and
#: ``y - x1``) is below this times ``1 + |bound of x_{k+1}|`` at every sample: a wrong structure
#: differs by O(1).
TRIANGULAR_CHECK_RTOL: float = 1e-9

#: Jacobian bounds (paper 004, eqs. 4-5) found by dense sampling plus refined critical points are
#: widened outward by this fraction of ``max |f'|`` on the interval: the refined extrema are exact
#: to brentq's ~1e-12, so the widening only covers rounding and a critical-point pair narrower than
#: one sampling cell; it is far too small to change a monotonicity verdict (see next tolerance).
JACOBIAN_BOUND_RTOL: float = 1e-7

#: A function counts as monotonic on an interval when its derivative never has the "wrong" sign
#: by more than this fraction of ``max |f'|``: twice the widening above, so a derivative that only
#: touches zero at an end point (cos on [0, 80 deg]) stays monotonic after widening.
MONOTONIC_RTOL: float = 2e-7

#: ``augment_parameters``: relative tolerance of the checks that a parameter enters a PWA system
#: affinely and only through its affine terms and guard offsets (the system data are computed in
#: double precision from the parameter, so an affine dependence reproduces to ~1e-15).
AFFINE_PARAMETER_RTOL: float = 1e-9

#: A state counts as an equilibrium (``lmi.impossibility``) when ``||x'|| <= EQUILIBRIUM_RTOL (1 + ||x||)``
#: at zero input: rounding of the model's functions at a true equilibrium is ~1e-16.
EQUILIBRIUM_RTOL: float = 1e-9

#: A candidate symmetry of the model (:mod:`hybobs_opt.lmi.impossibility`) holds at a sample point
#: when both sides agree to this, relative: a true symmetry reproduces to the rounding of the
#: model's functions (~1e-15), a false one differs by far more at some of the random points.
SYMMETRY_RTOL: float = 1e-9

#: Floor of the natural rate and of the scheduling coordinate's rate in the automatic switched-gain
#: design (:mod:`hybobs_opt.lmi.auto_design`): a plant at rest on its whole box would otherwise give
#: a zero gain bound, decay and rate; the floor is far below any rate a moving plant has.
AUTO_DESIGN_RATE_FLOOR: float = 1e-12

#: Initial-region selection of the switched-gain observer: an output whose model value varies over
#: the grid by less than this (variance relative to its mean square) does not depend on the
#: scheduling coordinate and is ignored: dividing by a variance at rounding level would let
#: rounding pick the region.
SWITCHED_INIT_SPREAD_RTOL: float = 1e-12

# ====================================================================== LMI / SDP

#: Smallest eigenvalue of a Lyapunov matrix returned by an LMI solve relative to its largest
#: (:func:`hybobs_opt.lmi.solve.checked_lyapunov`): below it ``P`` is singular to working precision
#: and the gain ``P^-1 Y`` is not determined by the answer.
LYAPUNOV_MIN_RATIO: float = 1e-12

#: Observer LMIs are solved as ``B(P, Y) <= -margin I`` with ``P >= I`` in box-scaled coordinates.
#: The LMIs are homogeneous there, so any positive margin is no loss of generality; it keeps the
#: returned point strictly inside the cone so that Clarabel's 1e-8 feasibility error cannot push
#: it out of ``B <= 0``, which numpy then re-checks.
LMI_STRICT_MARGIN: float = 1e-6

#: Strictness margin of the Luenberger decay LMIs of paper 000 (time-normalised so the data are of
#: order one, P >= I).  Any positive value is no loss of generality; it keeps Clarabel's point
#: inside the cone.  The decay actually used is recomputed with numpy from the returned P and gain.
LUENBERGER_LMI_MARGIN: float = 1e-6

#: A gain returned by an observer LMI with ``||L||_2 <= l`` counts as within the bound when
#: ``||L||_2 <= l (1 + GAIN_BOUND_RTOL)``: the bound is imposed through a Schur complement solved to
#: ~1e-8, so the recomputed norm can exceed it by rounding only.
GAIN_BOUND_RTOL: float = 1e-6

#: The IPOPT polish of the exact-gain-bound search (:mod:`hybobs_opt.lmi.gain_search`), in the frame
#: where the current ``P`` is the identity and time is scaled by the current rate: ``P = R R^T +
#: floor I`` keeps ``P`` positive definite; the start is the current pair at ``1 - margin`` times its
#: rate (so the slack factors start positive definite); IPOPT's tolerance and Nelder-Mead's on the
#: eigenvalue bound.  Nothing they decide is trusted: every point is re-certified in numpy.
GAIN_SEARCH_P_FLOOR: float = 1e-3
GAIN_SEARCH_START_MARGIN: float = 1e-3
GAIN_SEARCH_SOLVER_TOL: float = 1e-10

#: A candidate of the exact-gain-bound search replaces the best pair only when its re-checked rate is
#: larger by this fraction: rates equal to rounding come out the same on every machine, so the pair
#: returned does not depend on which of two equal candidates a processor's last bits favour.
SEARCH_IMPROVEMENT_RTOL: float = 1e-6

#: The numpy re-check of the noise LMI (:mod:`hybobs_opt.lmi.noise_gain`) makes every vertex block's
#: largest eigenvalue at most ``-2 x this`` times the blocks' norm (balanced coordinates), so that the
#: rounding of numpy's eigenvalues (about ``n eps ||B||``, 1e-15 for these sizes) and of the
#: round trip to model units cannot turn the re-check's ``<= 0`` into a false pass or fail.
NOISE_LMI_ROUNDING_RTOL: float = 1e-12

#: The numpy repair of a solver's point of the noise LMI may lower ``alpha`` and raise the ellipsoid's
#: level by at most this fraction: Clarabel's points violate the blocks by about its 1e-8 relative
#: feasibility tolerance, which the repair absorbs at a cost far below this; a point that needs more
#: is not an answer to the problem posed (the next solver of the chain is tried).
NOISE_LMI_REPAIR_RTOL: float = 1e-4

#: A required decay rate ``r`` that the noise design refuses is certified unreachable at ``r (1 - this)``:
#: strict infeasibility of the polytopic condition there excludes every non-strict solution at
#: ``alpha >= r``; 1e-6 is far below the decay searches' 5 % resolution and far above rounding.
NOISE_RATE_CERTIFICATE_RTOL: float = 1e-6

#: A noise-bound design's stated per-state bound and level must equal ``sqrt(level (P^-1)_kk)`` and
#: ``sum(mu) / alpha`` recomputed from its ``P``, ``mu`` and ``alpha`` to this relative accuracy: both
#: come from the same numpy formulas, so only rounding (the inverse of a scaled ``P`` of condition
#: number up to ~1e6) separates them.
NOISE_BOUND_RECHECK_RTOL: float = 1e-9

#: The decay-rate search of the location observer (paper 000) asks for this fraction more than the
#: rate the residual bound needs at Delta, so that the rounding of the numpy-verified decay cannot
#: undo the guarantee.
DELAY_DESIGN_RTOL: float = 1e-3

#: The dwell-time bisection stops once ``tau * max_j sigma_j`` is below this (``exp(-tau sigma)``
#: within 1e-4 of 1: the pair constraints are then at the strict margin's resolution).
TAU_RATE_FLOOR: float = 1e-4

#: Positive-observer LP (paper 003): the largest contraction rate per visible event that is tried
#: is ``1 - this``: a rate of 1 proves nothing, and a rate within rounding of 1 proves no more.
POSITIVE_LP_RATE_MARGIN: float = 1e-6

#: Arrival-cost LMI (:mod:`hybobs_opt.mhe.arrival`), in coordinates scaled by the first prior's
#: standard deviations: eigenvalues of the information below this fraction of its largest are
#: set to zero (the solver's interior point leaves ~1e-9 where the optimum has none), and it is
#: the tolerance of the re-check of ``Z >= 0`` and ``Z <= Z_0``.  The per-mode invariance is
#: re-checked with no tolerance (see ARRIVAL_CONTRACTION_MARGIN).
ARRIVAL_LMI_RTOL: float = 1e-7

#: The invariance of the arrival-cost LMI is solved as a strict contraction
#: ``F_q(P) <= (1 - margin) P``: an invariance met only to the solver's tolerance (1e-9 per step)
#: drifts without bound along a direction whose error never decays (on the backlash of model (16)
#: the Kalman information falls 0.1 % below the prior's within 776 steps), while the margin's slack
#: absorbs it and costs a relative 1e-6 of information.
ARRIVAL_CONTRACTION_MARGIN: float = 1e-6

# ====================================================================== certificates re-checked in numpy

#: Dual (Farkas) certificates of infeasibility of the observer LMIs, re-checked in numpy: Z is
#: accepted as PSD, W as PSD and the Y-coefficient as zero when their violations are below this
#: times ``||Z||_F`` (after an exact projection that zeroes the Y-coefficient).  Clarabel's rays
#: are accurate to ~1e-9 relative; anything above 1e-6 is a wrong certificate, not rounding.
CERTIFICATE_RTOL: float = 1e-6

#: Farkas rays of :mod:`hybobs_opt.lmi.farkas`, re-checked in numpy: ``||A^T y|| <= FARKAS_RTOL
#: ||A|| ||y||`` and cone membership to ``FARKAS_RTOL ||y||``, on the conic standard form cvxpy
#: compiles for Clarabel.  Clarabel's rays are accurate to ~1e-9 relative (as for
#: CERTIFICATE_RTOL); a ray that is no certificate violates these by far more.
FARKAS_RTOL: float = 1e-7

#: A Farkas ray must also make ``b^T y <= -FARKAS_MARGIN ||b|| ||y||``: a ray that makes ``b^T y``
#: negative only at rounding level proves nothing.
FARKAS_MARGIN: float = 1e-9

#: A Perron (Collatz-Wielandt) certificate ``Phi z >= r z`` (paper 003) is re-checked in numpy with
#: this relative slack on ``r z``: the eigenvector comes from LAPACK to ~1e-15.
PERRON_RTOL: float = 1e-9

# ====================================================================== MHE / MIQP
# (paper 002, eq. 10; hybobs_opt.mhe).  Constraint rows of the MLD encoding have a largest
# coefficient of one and the variables are scaled to the state box, so these are relative.

#: A guard row is left out of the big-M encoding when its largest value minus its right-hand side
#: over X x U is at most this (relative to the row's size): it holds on the whole domain.
BIGM_IMPLIED_RTOL: float = 1e-9

#: Proximal weight of the MIQP (scaled cost units, where the largest diagonal entry of the output
#: part of the Hessian is one).  DAQP's branch-and-bound needs a positive-definite Hessian, but the
#: big-M copies and the binaries have no curvature in eq. (10): the term ``eps ||v - v_bar||^2``
#: towards the warm start ``v_bar`` supplies it.  Its effect on the optimum is bounded (reported
#: as ``gap_bound``) and is removed from the estimate by the fixed-sequence polish; it must stay
#: well below the output sensitivity of the weakest observable direction (about 1e-7 for model
#: (16) at T = 3), which 1e-10 does.
MHE_PROX_WEIGHT: float = 1e-10

#: Proximal weight of the MIQP's binaries (scaled units).  It steers the branch-and-bound towards
#: the incumbent's mode sequence and biases the choice between two sequences by at most this per
#: changed binary (included in ``gap_bound``).  Smaller values (1e-12) are still factorised by
#: DAQP but resolve the nearly indistinguishable sequences of model (16) no better (measured
#: against enumeration on noisy windows: larger excess cost, not smaller), so it equals
#: MHE_PROX_WEIGHT.
MHE_BINARY_PROX_WEIGHT: float = 1e-10

#: Absolute optimality gap of the MIQP branch-and-bound (same scaled units): a node is pruned when
#: its bound is within this of the incumbent.  The cost is a sum of squares plus the proximal
#: term, so no relaxation is below zero: once the warm start gives a zero-cost incumbent (noise-
#: free data) every node is pruned at once instead of every node whose relaxation also fits the
#: data being explored.  It only has to absorb rounding in the objective (about 1e-16 of the
#: output energy), and it is kept far below the cost differences between mode sequences of
#: model (16) (1e-10 in these units).  Added to ``gap_bound``.
MHE_ABS_SUBOPT: float = 1e-12

#: A binary of a returned solution counts as integral when within this of 0 or 1.
MHE_INTEGRALITY_TOL: float = 1e-6

#: Largest violation of a constraint row of the MLD encoding (largest coefficient one, scaled
#: variables) accepted in a returned solution; larger means the solver's answer is not certified.
MHE_FEASIBILITY_TOL: float = 1e-6

#: Feasibility tolerance asked of the MILP solvers (HiGHS primal and MIP feasibility), in the same
#: scaled units: tighter than MHE_FEASIBILITY_TOL so that accepted answers pass the check.
MHE_MILP_FEASIBILITY_TOL: float = 1e-9

#: The fixed-sequence polish of the MIQP is skipped when the solution's continuous part is within
#: this (scaled units) of the warm start and its mode sequence equals the warm start's: the
#: proximal term then moves the optimum by about MHE_PROX_WEIGHT times this over the output
#: sensitivity (1e-18 / 1e-7 = 1e-11 of the state range for model (16)), far below any tolerance.
MHE_POLISH_SKIP_TOL: float = 1e-8

#: A warm start whose exact cost is below this times the largest output curvature of the MIQP
#: (``J_s``, about the squared output range) is accepted as the optimum without branch-and-bound:
#: the cost of eq. (10) is a sum of squares, so the optimum is at least zero and the accepted
#: point is within this of it.  Noise-free data give 1e-25 relative; 1e-14 of 9e4 (rad/s)^2 for
#: model (16) is a residual of 1.7e-5 rad/s, below the solver tolerances of the MIQP itself.
MHE_ZERO_COST_RTOL: float = 1e-14

#: Relative optimality gap a certified MIQP window must prove: ``cost - optimum <=
#: max(MHE_CERTIFIED_RTOL * cost, MHE_ZERO_COST_RTOL * J_s)``.  The proximal certificate of the
#: branch and bound (``gap_bound``, the proximal term over the whole box: 4.7e-4 on model (16))
#: reaches it only on zero-cost windows; the others are certified by the exact prefix search of
#: :mod:`hybobs_opt.mhe.certify`, whose bounds close to about 1e-10 on noisy windows of model (16)
#: (optima 1e-6 .. 6e-5, output noise 0.01 rad/s).  The absolute floor is the zero-cost threshold.
MHE_CERTIFIED_RTOL: float = 1e-6

#: Rounding allowance of a weak-duality lower bound of a mode sequence's LP computed in numpy
#: (solver ``"sequences"``, :mod:`hybobs_opt.mhe.sequence_lp`): the bound is lowered by this times
#: the sum of the magnitudes of its terms.  Each term carries a relative rounding error of a few
#: units of 2.2e-16 per product summed (at most a few hundred rows), so 1e-13 covers the
#: accumulated error with a margin while staying far below MHE_CERTIFIED_RTOL.
SEQUENCE_LP_BOUND_RTOL: float = 1e-13

#: Floor of the certified gap of solver ``"sequences"``, as a fraction of the zero-cost threshold
#: ``J_0``: its gap is ``MHE_CERTIFIED_RTOL * cost``, but never required below this times ``J_0``.
#: Its bounds resolve the optimum only to their rounding allowance (SEQUENCE_LP_BOUND_RTOL times
#: the size of the data's terms): 5e-11 .. 2.1e-10 on noisy windows of model (16), where
#: ``J_0 = 3e-5`` and MHE_CERTIFIED_RTOL * J_0 = 3e-11 would leave such windows uncertified.
#: The floor, 3e-9 there, is 15 times the largest allowance measured and 1e4 times below ``J_0``.
SEQUENCE_LP_GAP_FLOOR: float = 1e-4

#: Proximal weight of DAQP's LP mode on a mode sequence's LP (solver ``"sequences"``, cost per
#: unit of the scaled variables): DAQP solves an LP as proximal-point QPs and needs a positive
#: weight.  Nothing is taken from DAQP on trust: its point is checked against the rows and its
#: cost recomputed, its multipliers give a bound proven in numpy, and when that bound is not
#: within the certified gap of the point's cost the LP is solved again by HiGHS.
SEQUENCE_LP_DAQP_PROX: float = 1e-6

#: Candidate active sets of an interior-point answer (the uniqueness test's robust QP bound): a
#: row counts as met within this fraction of ``1 + |g|`` ...
KKT_ACTIVE_SLACK_RTOL: float = 1e-9
#: ... or when its multiplier is within this fraction of the largest.  Any candidate that passes
#: the checks is a KKT point, so these choose where to look, never what is accepted.
KKT_ACTIVE_MULTIPLIER_RTOL: float = 1e-6

#: An extension's norm-2 cost term (``MHEObserver(extend=...)``) is convex when its Hessian's
#: smallest eigenvalue is at least ``-MHE_EXTENSION_PSD_RTOL`` times its largest; eigenvalues
#: below that (in absolute value) count as zero curvature.  The Hessian is exact (CasADi's
#: symbolic derivative of a quadratic), so only rounding of its coefficients is allowed for.
MHE_EXTENSION_PSD_RTOL: float = 1e-10

#: The linear part of an extension's norm-2 cost must lie in the range of its Hessian (the term is
#: a sum of squares): its component outside, relative to its largest coefficient, at most this.
MHE_EXTENSION_RANGE_RTOL: float = 1e-9

#: Floor of the standard deviations of the MHE's Kalman arrival prior
#: (``MHEObserver(arrival_weight="kalman")``), relative to the state box's half-widths, added to
#: the filter's covariance (a model-mismatch floor: the prior never claims more than this).
#: Without process noise the filter's covariance shrinks without end along observable stretches
#: and the arrival block of DAQP's Hessian grows with it.  On the noisy bench of model (16)
#: (sigma 0.01 rad/s, 1,500 samples) a floor of 1e-6 makes the branch and bound's points fail
#: their verification and leaves the relative gap unproven by the prefix search in 1,269 windows
#: (fallback); at 1e-4 and 1e-3 none fails (1,489 observable), with omega_l RMS 0.013 / 0.016
#: rad/s and median steps 6.9 / 4.7 ms.
MHE_ARRIVAL_MIN_STD_RTOL: float = 1e-3

# ---------------------------------------------------------------------- MHE uniqueness (paper 002, eq. 10)
# The MHE flags a window "observable" only when no admissible window-start state at least
# MHE_UNIQUENESS_DELTA (hybobs_opt.defaults) away (inf-norm, coordinates scaled by the
# half-widths of X) reaches a cost within epsilon of the optimum; see hybobs_opt.mhe.observer.

#: Epsilon of the uniqueness test (norm 2): an alternative counts when its cost is at most
#: J* + this * S_y, S_y one sample's squared weighted output half-range (norms 1 / inf: the square
#: roots).  Noise-free data give J* ~ 1e-30 S_y.  It sits above DAQP's accuracy on the MLD
#: encoding once the proximal term no longer hides it (~1e-13 S_y) and below the separated cost
#: of model (16)'s observable windows (8.9e-11 S_y, see MHE_UNIQUENESS_DELTA): the output of an
#: alternative then differs by at least 1e-6 of the output half-range.
MHE_UNIQUENESS_COST_RTOL: float = 1e-12

#: Absolute floor of that epsilon (cost units): it only keeps epsilon positive when the output
#: range vanishes (an output constant over X x U); any output half-range above 1e-4 units makes
#: the relative term larger.
MHE_UNIQUENESS_COST_ATOL: float = 1e-20

#: Decision band of the uniqueness test, as a fraction of epsilon: a separated cost within
#: ``max(this * epsilon, MHE_DECISION_BAND_COST_RTOL * |J* + epsilon|)`` of the threshold
#: ``J* + epsilon`` is neither an alternative nor proof of uniqueness.  The window is then "not
#: certified" (a fallback, the safe side) whatever the rounding, so that a machine whose BLAS
#: rounds differently cannot flip the flag.  Noise-free data: a residual near 1e-6 of the output
#: range (a cost near epsilon) carries a rounding of ~1e-16 of the range, 2e-10 of the cost, well
#: inside 1e-6; the separated costs of model (16)'s observable windows (8.9e-11 S_y) lie 1e7
#: bands away.
MHE_DECISION_BAND_EPS_RTOL: float = 1e-6

#: Second term of the decision band: a fraction of the threshold itself, above the rounding of a
#: large cost (a sum of many squares, ~1e-15 of its value).
MHE_DECISION_BAND_COST_RTOL: float = 1e-12


def mhe_decision_band(threshold: float, epsilon: float) -> float:
    """Half-width of the band around the uniqueness threshold ``J* + epsilon`` inside which the
    MHE's uniqueness test decides nothing (see :data:`MHE_DECISION_BAND_EPS_RTOL`)."""
    return max(MHE_DECISION_BAND_EPS_RTOL * abs(float(epsilon)), MHE_DECISION_BAND_COST_RTOL * abs(float(threshold)))


#: Proximal weight of the uniqueness MIQP (same scaled units as MHE_PROX_WEIGHT).  The cutoff
#: J* + epsilon is widened by the term's largest value at an integral point of the box (sum of
#: the squared box ranges ~50 on model 16: 5e-12 S_y, five times epsilon); a minimum in that band
#: is resolved by excluding its mode sequence exactly (QP) and searching the rest again.  It is
#: the first rung of a ladder (x3, x10, ...): the observer takes the first whose Hessian DAQP
#: factorises with zero_tol a tenth of it (1e-13 on model 16 at T = 3; 3e-13 from ~40 variables,
#: DAQP's own factorisation losing ~nv * 1e-16 on the pivots; 1e-14 never passes).
MHE_UNIQUENESS_PROX_WEIGHT: float = 1e-13

#: Rounding allowance of a closed-form direction bound of the uniqueness search over mode
#: prefixes (:mod:`hybobs_opt.mhe.unique_search`), relative to the sum of the magnitudes of its
#: terms: a Cholesky solve of a few variables loses ~1e-15 of them times the condition number,
#: at most MHE_DIRECTION_COND_MAX; the margin stays far below epsilon (1e-12 S_y) at the costs of
#: model (16) (1e-9 of a cost ~1e-3 is 1e-12, against an epsilon of 9e-8).
MHE_DIRECTION_BOUND_RTOL: float = 1e-9

#: Largest condition number of a prefix's ``R'R`` for which that closed-form bound is used (above
#: it the direction stays open at that node and is decided deeper or by the exact QP).
MHE_DIRECTION_COND_MAX: float = 1e6

# ====================================================================== set-membership observers and stated radii

#: The set-membership observer's box is widened on each side by this fraction of the state box's
#: half-widths: its MILPs hold their rows to HiGHS's feasibility tolerance (1e-9, scaled), so a
#: bound is exact to about that level, not to the last bit.  Model (16) noise-free: the true state
#: lies up to 3e-11 outside the unpadded box (omega_l, half-width 50: 6e-13 of it).
SET_MEMBERSHIP_BOX_RTOL: float = 1e-8

#: The set-membership observer's check of an extreme point against its MILP's dual bound: the
#: point's value may lie this much (relative to ``1 + |value|``) beyond the bound -- HiGHS's
#: feasibility tolerance, not a disagreement.
SET_MEMBERSHIP_BOUND_RTOL: float = 1e-7

#: Rounding allowance when a true state is compared with a stated radius (``|x^ - x| <= r (1 +
#: RADIUS_CHECK_RTOL) + RADIUS_CHECK_ATOL``, :meth:`~hybobs_opt.contract.ObserverTrace.n_outside_radius`):
#: the subtraction ``x^ - x`` rounds at ~1e-16 of the state; the radii carry their own pad
#: (:data:`SET_MEMBERSHIP_BOX_RTOL`), so this only keeps a state on the boundary inside.
RADIUS_CHECK_RTOL: float = 1e-9
RADIUS_CHECK_ATOL: float = 1e-12

#: Bounded-noise lookup observer (``NoiseAwareLookupObserver(noise_bound=...)``): a residual row of a
#: mode sequence may exceed its noise bound by this much, relative to ``1 + max |residual|`` in
#: whitened units, and the sequence still counts as fitting -- the rounding of the table's
#: arithmetic (a few ulps of the data), never a decision the noise could take.  Wider only keeps
#: more candidate sequences, hence a larger radius: the safe side.
BOUNDED_RESIDUAL_RTOL: float = 1e-9

#: Set-membership filter (:class:`~hybobs_opt.observers.set_filter.SetMembershipFilter`): every row
#: ``a' s <= b`` of a piece (scaled state coordinates) is relaxed to ``a' s <= b + rtol (|a| + |b|)``
#: before its emptiness test, and the relaxed piece is kept: rounding in the LPs and in the affine
#: maps can then never drop the true state, at the price of a set larger by about ``rtol`` of the
#: state box per step (3e-7 after 3,000 steps).
SET_FILTER_ROW_RTOL: float = 1e-10

#: Set-membership filter: the noise bound it uses is at least this fraction of each output's range
#: (noise-free data would otherwise make every piece a slab thinner than HiGHS's feasibility
#: tolerance, decided by rounding); a wider bound keeps more states, never fewer.
SET_FILTER_MIN_NOISE_RTOL: float = 1e-7

#: Set-membership filter: the pieces lie in the unit box of ``X`` (scaled), relaxed:
#: ``|s_i| <= 1 + SET_FILTER_UNIT_BOX_MARGIN`` bounds the residual term of the proven box bounds.
#: The pieces' rows are relaxed by SET_FILTER_ROW_RTOL at every step (3e-7 of the box after 3,000
#: steps), so they may reach that far beyond the unit box; the margin covers it.
SET_FILTER_UNIT_BOX_MARGIN: float = 1e-6

#: Set-membership filter: a row of a piece is redundant when the other rows keep it within this
#: (relative) of its bound.  Dropping a row that still cuts off up to this much enlarges the piece
#: by at most that (the safe side: the true state is never dropped), at the level of the rows' own
#: relaxation.
SET_FILTER_REDUNDANCY_RTOL: float = 1e-9

# ====================================================================== lookup observer (paper 002, Algorithm 4.1)

#: A region test [x_i; U] in P_i passes when every row (unit-norm in scaled coordinates) is
#: violated by at most this; far above the rounding of C_i^+ (about 1e-12 relative) and far below
#: any real excursion out of a region.
LOOKUP_MEMBERSHIP_TOL: float = 1e-7

#: The output equality C_i x_i = Y - D_i U - f_i of eq. (12) holds when its residual is below
#: this times max(1, |Y|_inf).  Noise-free data give about 1e-13; raise it (output_rtol=...) for
#: noisy measurements.
LOOKUP_OUTPUT_RTOL: float = 1e-8

#: Two candidates of chi are the same state when they differ by less than this in coordinates
#: scaled by the state bounds (a state on the common boundary of two regions).
LOOKUP_SAME_STATE_TOL: float = 1e-6

#: A candidate must lie *strictly* inside its region P_i, by this margin (rows unit-norm in scaled
#: coordinates).  The paper's regions are not closed: when the true shaft enters the backlash,
#: the data force the contact region's candidate exactly onto the guard boundary, which belongs
#: to the backlash sequence.  States closer than this to a boundary are flagged unobservable
#: (conservative), never wrongly reconstructed.
LOOKUP_INTERIOR_MARGIN: float = 1e-9

#: The rows of a region that only bound an input (the copies of U for each step) are tested
#: *closed*, ``<= LOOKUP_INPUT_BOUND_TOL`` (unit rows in scaled coordinates), unlike the strict
#: guard rows: nothing lies beyond U, so an input resting on its bound (zero engine torque) must
#: not empty chi.  The same tolerance makes a sample *bad* when its input leaves U by more: 1e-9 of
#: the input's half-range (7e-8 N m for T_m in [0, 140]) is far above the rounding of an input
#: stored at its bound and far below any real excursion.
LOOKUP_INPUT_BOUND_TOL: float = 1e-9

# ---------------------------------------------------------------------- C export of the lookup observer
# (hybobs_opt.observers.c_export).  The double export uses the observer's own tolerances above;
# these are the simplex of its B~_T LPs and the single-precision variant.

#: The exported simplex of a B~_T LP (``max t``, rows unit-norm in scaled coordinates, entries of
#: order one): a tableau entry is a pivot candidate above this, far above the rounding of a few
#: pivots (~1e-15) and far below the entries of a non-degenerate piece.
C_EXPORT_LP_PIVOT_TOL: float = 1e-11

#: The exported simplex: a reduced cost counts as improving above this (rounding of the objective
#: row after a few pivots is ~1e-15; a real improvement moves ``t`` by far more than 1e-12).
C_EXPORT_LP_COST_TOL: float = 1e-12

#: ``float32`` export: single precision resolves 2^-23 = 1.2e-7 of each term, and the table
#: products sum O(10) terms of magnitude up to ``|Y|`` (candidates, residuals) or O(1) in scaled
#: units (membership rows), so noise-free data leave residuals and memberships of ~1e-6.  The
#: output equality of eq. (12) passes below this times ``max(1, |Y|_inf)`` (``output_rtol`` of the
#: observer when that is larger).
C_EXPORT_F32_OUTPUT_RTOL: float = 1e-5

#: ``float32`` export: a candidate must lie this far inside its region's guard rows (scaled, unit
#: rows): above the ~1e-6 rounding of a membership value in single precision, so that a candidate
#: the data put exactly on a guard (the backlash entry) is rejected as in double precision.
C_EXPORT_F32_INTERIOR_MARGIN: float = 1e-5

#: ``float32`` export: the rows of ``U`` (and the bad-sample test of an input) are closed up to
#: this: an input stored at its bound computes to within ~1e-7 of it in single precision.
C_EXPORT_F32_INPUT_BOUND_TOL: float = 1e-5

#: ``float32`` export: two candidates are the same state within this (scaled coordinates);
#: single-precision candidates of one state differ by ~1e-6.
C_EXPORT_F32_SAME_STATE_TOL: float = 1e-4

#: ``float32`` export: membership of the ``B~_T`` screen rows and the LP's decision ``t > -tol``
#: (single-precision memberships carry ~1e-6 of rounding).
C_EXPORT_F32_MEMBERSHIP_TOL: float = 1e-5

#: ``float32`` export: pivot threshold of the simplex (entries of order one, rounding ~1e-7).
C_EXPORT_F32_LP_PIVOT_TOL: float = 1e-5

#: ``float32`` export: improving reduced cost of the simplex (rounding of the objective row ~1e-7).
C_EXPORT_F32_LP_COST_TOL: float = 1e-6

#: ``float32`` export: refused when the a priori rounding of the candidates of eq. (13) in single
#: precision (``c_export._float32_rounding``: data at the ends of the model's output and input
#: ranges, every table term rounded) exceeds this fraction of the states' half-ranges.  The bound is
#: pessimistic: model (16) has 0.7 % (T = 3) and 1.3 % (T = 5), while its reconstructions on the bench
#: scenario differ from double precision by at most 0.007 % and 0.002 % of the half-ranges, with every
#: flag equal; model (17) at T = 5 has 1080 % (C_i^+ amplifies the rounding of the engine speed), and
#: its single-precision export flags 402 of 3,000 windows observable that double precision places
#: in B~_T.
C_EXPORT_F32_MAX_ROUNDING: float = 0.05

# ====================================================================== other observers at run time

#: Location observer (paper 000): relative slack (times 1 + |b|) added to the guaranteed margin of
#: a location's invariant test on its generator's state.  It covers rounding and the plant's event
#: instants falling between samples; it is far below the widths of the invariants of interest.
LOCATION_INVARIANT_RTOL: float = 1e-9

#: ``ParameterBank``: a running innovation score below this (squared half-widths of the state
#: box) is zero -- an exact model reconstructs to rounding (1e-16 per coordinate, squared).
BANK_SCORE_ATOL: float = 1e-18

#: Relative floor of every range test of the observer contract (``(1 + |bound|)`` times this,
#: :func:`hybobs_opt.contract.outside_range`): a degenerate range (a constant output) still admits
#: rounding.
RANGE_ABS_RTOL: float = 1e-9

#: Relative error (to ``max(1, |x|)``) above which an estimate flagged observable counts as wrong
#: in a summary against a noise-free log (:mod:`hybobs_opt.observers.recorded`): far above the
#: rounding of an exact reconstruction from logged data, far below the error of a wrong estimate.
WRONG_ESTIMATE_RTOL: float = 1e-6

#: Largest deviation of a log's sample intervals from their median, relative to it, for a
#: continuous-time observer that needs one sampling period: far above the rounding of time stamps
#: accumulated in doubles, far below a missing or doubled sample (a deviation of 100 %).
UNIFORM_PERIOD_RTOL: float = 1e-6

# ====================================================================== simulation and integration

#: Relative / absolute tolerances of the adaptive ODE solver of the nonlinear simulator: tight
#: enough that the sampled trajectory is exact for the physics checks of the examples (turn angles
#: to 1e-6 rad), loose enough to keep a 30 s vehicle scenario well under a second.
NONLINEAR_ODE_RTOL: float = 1e-10
NONLINEAR_ODE_ATOL: float = 1e-10

#: Relative / absolute tolerances of the ODE solver of the hybrid-automaton simulator
#: (:mod:`hybobs_opt.sim.hybrid`) between events; events are located to about this accuracy, a
#: hundred times tighter than EVENT_MEMBERSHIP_RTOL.
HYBRID_ODE_RTOL: float = 1e-9
HYBRID_ODE_ATOL: float = 1e-12

#: Relative offset of the event threshold of invariant rows that are active when a segment starts.
#: Events fire on upward crossings only and the state moves inwards after a jump, so the offset
#: only has to absorb rounding of the located event point (about 1e-16), not model error.
EVENT_OFFSET_RTOL: float = 1e-12

#: Relative slack with which a located event point is accepted in a guard or target invariant:
#: the event root is located to about HYBRID_ODE_RTOL, a hundred times tighter than this.
EVENT_MEMBERSHIP_RTOL: float = 1e-7

#: Relative slack of the end-of-segment check that the state is still in its location's
#: invariant (a crossing missed inside one solver step shows up far above this).
SEGMENT_END_RTOL: float = 1e-6

#: Times closer than this (seconds) are the same instant in the hybrid simulator (segment ends,
#: breakpoints, grid): far above the rounding of times summed from the grid, far below any step.
HYBRID_TIME_EPS: float = 1e-12

#: Step (in units of the flow) of the probe that decides which of several target locations the
#: flow enters from a shared boundary point: far below any invariant's width, far above rounding.
HYBRID_ENTRY_PROBE: float = 1e-9

#: Switched-gain observer: RK4 sub-steps are chosen so that (sub-step) x (spectral radius of the
#: frozen error dynamics) stays below this: well inside RK4's stability interval (2.78 on the
#: negative real axis).
RK4_STEP_RADIUS: float = 0.5

#: Relative slack with which a time of an input table (``simulate --inputs``) is taken as the
#: sample time ``k Ts`` of a discrete-time run: times written to ~9 digits in a CSV file still
#: match, a row off by a fraction of a sample does not.  The absolute slack is this times ``1e-3 Ts``
#: (the row at ``t = 0``).
INPUT_TABLE_TIME_RTOL: float = 1e-9

#: Absolute tolerance of the last check scipy's ``linprog`` makes of a HiGHS "optimal" point
#: (``sqrt(1e-9) * 10``, its ``_check_result``): the LP layer poses its LPs to HiGHS as ``linprog``
#: does (:func:`hybobs_opt.geometry.lp.solve_lp`), and a point outside it is a numerical failure
#: there, so there too (the next HiGHS method runs) -- the same answers as through ``linprog``.
LINPROG_CHECK_TOL: float = 0.00031622776601683794
