"""Named design defaults and budgets.

A default is a value a user could reasonably choose differently: a horizon, a run length, a
bound on a gain or a rate, a grid size, the number of nodes, solves or iterations a search may
spend, a probability of false alarm.  Every such value of the toolbox is defined here with the
reason for its size; most are the default of a keyword argument that overrides them.  Thresholds
that decide a numerical question (rounding, solver accuracy) are in :mod:`hybobs_opt.tolerances`;
refusals of requests too large to run are in :mod:`hybobs_opt.limits`.
"""

# ====================================================================== horizons and run lengths

#: The horizon every command uses when ``--horizon/-T`` is not given (regions, observe, bench,
#: report): the papers' powertrain studies run at ``T = 3``.
DEFAULT_HORIZON: int = 3

#: Samples of a PWA run (:func:`hybobs_opt.sim.any_system.simulate`) when neither ``steps`` nor
#: ``t_final`` is given: a short run, instant to compute; a study passes its own length.
SIM_PWA_STEPS: int = 100

#: Final time of a continuous-time run when ``t_final`` is not given (time units of the model): a
#: round number for a first look; the examples and studies pass their own scenario's length.
SIM_T_FINAL: float = 10.0

# ====================================================================== geometry: exact paths and iteration budgets

#: Largest dimension in which ``Polytope.volume(method="auto")`` is exact (qhull on the
#: vertices); above it the volume is estimated by Monte Carlo.  ``method="exact"`` works in any
#: dimension, but qhull's triangulated hull of a 6-D polytope can hold 10^5 simplices (0.3-0.8 s).
EXACT_VOLUME_MAX_DIM: int = 4

#: A degenerate vertex (more than d tight rows) is checked by walking every extreme ray of its
#: cone of feasible directions, found among the null directions of the (d-1)-subsets of its tight
#: rows.  Above this many subsets (e.g. the 32 rows at a vertex of the 6-D cross-polytope give
#: 201,376) the check gives up and the hand-written path answers instead.
VERTEX_DEGENERATE_MAX_SUBSETS: int = 5000

#: Safety cap on the support LPs of one iterative-hull projection; reaching it means the hull
#: does not converge (numerical trouble), which raises :class:`~hybobs_opt.errors.SolverError`.
HULL_MAX_SUPPORT_LPS: int = 20000

#: Equilibration sweeps of :func:`hybobs_opt.geometry.lp.solve_lp` (rows, then columns, by powers
#: of two, geometric mean of the largest and smallest entry) before every row is set to unit norm.
#: Each sweep about halves the logarithm of the imbalance; 8 sweeps bring states rescaled by 1e6
#: and 1e-6 (entries 1e12 apart within a row, which HiGHS drops below its 1e-9 small-value
#: threshold) within a factor of a few of one, for 4 x 8 small numpy reductions per LP.
LP_EQUILIBRATION_SWEEPS: int = 8

#: Simplex pivots after which :func:`hybobs_opt.geometry.exact_lp.exact_lp_optimum` gives up
#: (``None``): it bounds the time of one re-decision in rational arithmetic, whose cost grows
#: with every pivot (the numbers' sizes grow with them).
EXACT_LP_MAX_PIVOTS: int = 60

#: Ratio-test steps (at most) of each of the two walks that try to prove a set wider than a width
#: test's threshold before its LPs (:func:`hybobs_opt.geometry._lp_kernels.walk_width_lower_bound`),
#: and the fraction of the way to the stopping row that each step goes.  On model (17) at ``T = 7``,
#: 1, 2, 4 and 6 steps proved 60, 83, 94 and 97 % of the pair sets that needed width LPs wide
#: (none of those sets was thin); on the faces of ``T = 8`` (slabs ``CLOSED_SET_TOL`` thick), 4 steps
#: proved 99 of the 215 that were not thin, 8 steps 171.  A step costs one pass over the rows, and
#: the walks stop as soon as their points are far enough apart.
WIDTH_WALK_STEPS: int = 8
WIDTH_WALK_FRACTION: float = 0.99

#: Sweeps after which the Jacobi iteration of the reproducible singular values stops even if a pair
#: is still above JACOBI_TOL (:mod:`hybobs_opt.tolerances`): quadratic convergence takes 5-10 on
#: the matrices here; the answer is deterministic either way.
JACOBI_MAX_SWEEPS: int = 60

# ====================================================================== sampled checks of a model's functions

#: Number of points of each function's argument interval at which values and derivatives are
#: checked for NaN/Inf (and user derivatives against automatic differentiation) at construction.
#: A sample test, not a proof: a pole strictly between two samples is not seen.
FUNCTION_CHECK_SAMPLES: int = 257

#: Samples of the derivative per argument interval for the Jacobian bounds (paper 004, eqs. 4-5).
#: With the refinement of critical points this only has to resolve the sign pattern of ``f''``;
#: 1025 points resolve the 5 turns of the piston sensors' spiral with ~40 samples per half-turn.
JACOBIAN_BOUND_SAMPLES: int = 1025

#: Argument intervals per scalar function whose sampled derivative bounds are kept for re-use
#: (:func:`hybobs_opt.lmi.bounds.derivative_bound`): the regions of a design and of its bisections.
JACOBIAN_BOUND_CACHE_SIZE: int = 512

#: Samples per argument interval of a nonlinear output's range (then refined by a bounded scalar
#: search); the same resolution as JACOBIAN_BOUND_SAMPLES.
OUTPUT_RANGE_SAMPLES: int = 1025

#: Samples of the operating box used to check the triangular form of callable flows and to bound
#: ``f_q`` (the derivative of the last canonical state; paper 001).  20 000 uniform samples put the
#: largest gap along a coordinate at ~1e-4 of its range: for Example 2's
#: ``F2 = -40 cos(300 x3 + pi/2)`` (period 0.021 in x3 over [-1, 1]) the sampled peak is within
#: 0.3 % of the true one.
DERIVATIVE_BOUND_SAMPLES: int = 20_000

#: The sampled range of a callable ``f_q`` is widened by this fraction of itself on both sides, to
#: cover peaks between samples (see above: 0.3 % for Example 2) with a wide margin.  It enters the
#: last gain only, whose own margin SMO_GAIN_MARGIN then still holds.
DERIVATIVE_BOUND_MARGIN: float = 0.1

#: Box samples on which a callable flow's triangular structure is checked (each costs one call
#: per location; a wrong structure shows up at almost every sample).
TRIANGULAR_CHECK_SAMPLES: int = 200

#: Samples of the scheduling range searched for undetectable points by the impossibility
#: certificates (besides the roots of the output slopes and the range ends): 2^8 + 1 points, the
#: same resolution as FUNCTION_CHECK_SAMPLES.
DETECTABILITY_SAMPLES: int = 257

#: Random points at which a candidate symmetry of the model is checked (SYMMETRY_RTOL in
#: :mod:`hybobs_opt.tolerances`): a few hundred random points of the box expose a false symmetry
#: at a negligible cost; :meth:`~hybobs_opt.lmi.impossibility.OutputSymmetry.verify` re-checks at
#: fresh ones.
SYMMETRY_POINTS: int = 200

#: Largest number of sign patterns x centres tried by the symmetry search (exhaustive below it):
#: it bounds the search's cost, SYMMETRY_POINTS model evaluations per candidate.
MAX_SYMMETRY_CANDIDATES: int = 4096

# ====================================================================== observer design: LMIs, decay searches, gains

#: Bisection on the decay rate sigma and on the dwell time tau stops when the bracket is this
#: fraction of its upper end: 5 % is below the spread between regions, the design uses half the
#: largest rate anyway, and it keeps each search to about 8 solves.
BISECTION_RTOL: float = 5e-2

#: Re-solves of a condition's decay search with a larger internal gain bound (the LMIs bound
#: ``||L||_2`` sufficiently, through ``P >= alpha I``, so their gains usually stay well inside the
#: user's bound): the internal bound grows while the returned gain's own norm stays within the
#: user's bound (:mod:`hybobs_opt.lmi.decay_design`).
GAIN_BOUND_TIGHTENING_STEPS: int = 6

#: The internal bound stops growing once the returned gain uses this fraction of the user's bound.
GAIN_BOUND_TIGHT_FRACTION: float = 0.98

#: Exact-gain-bound search (:mod:`hybobs_opt.lmi.gain_search`).  Bisections inside the search stop at
#: this relative bracket: the rate kept is the re-checked rate of the pair, so a finer bracket only
#: changes where each step stops (0.5 % costs about 3 more solves per bisection than 5 %).
GAIN_SEARCH_RTOL: float = 5e-3

#: Convex-concave steps per start at most; the steps stop earlier once one gains less than
#: GAIN_SEARCH_MIN_GAIN (relative).  On the pendulum and the saddle system 2-6 steps converge; from
#: an ill-conditioned P (the robot, the vehicle) the steps creep (0.3 % each) and the IPOPT polish
#: gets further: 40 steps instead of 8 changed no final rate of the five systems of the decay oracle.
GAIN_SEARCH_CCP_STEPS: int = 8

#: Relative gain below which the convex-concave steps stop.
GAIN_SEARCH_MIN_GAIN: float = 1e-3

#: IPOPT iterations of one polish (the smooth NLP of the search, about 200 unknowns on the vehicle):
#: the converged polishes of the examples take 30-400.
GAIN_SEARCH_IPOPT_ITERATIONS: int = 1000

#: Polish rounds per start (each re-centred at the last certified pair), while one improves.
GAIN_SEARCH_POLISH_ROUNDS: int = 4

#: Eigenvalue screen: Sobol points of the gain box (rounded up to a power of two), the best kept for
#: Nelder-Mead on the eigenvalue bound, its evaluations per start, and the best certified.  On the
#: robot and the vehicle (8 unknowns) 4096 points, 16 kept and 3 certified find gains within 5 %
#: of the independent search's best in 3-10 s; the screen itself takes 0.1 s.
GAIN_SEARCH_SCREEN_SAMPLES: int = 4096
GAIN_SEARCH_SCREEN_KEEP: int = 16
GAIN_SEARCH_SCREEN_EVALUATIONS: int = 2000
GAIN_SEARCH_CERTIFY: int = 3

#: Switched noise bound (:mod:`hybobs_opt.lmi.switched_noise`): the common rates of the joint SDP, as
#: fractions of the smallest per-region optimum rate, and the couplings ``m`` as fractions of the way
#: from 1 to ``e^{alpha tau}`` (the largest jump the dwell time allows).  On the vehicle the best
#: candidates lie at 0.1-0.3 of the way (bounds 2.4 and 24.6 times the reference sizes); at 0.8 they
#: are 1.5-2 times worse, so the grid stops at 0.5: 12 SDPs.
SWITCHED_NOISE_ALPHAS: tuple[float, ...] = (0.25, 0.5, 1.0, 1.5)
SWITCHED_NOISE_COUPLINGS: tuple[float, ...] = (0.1, 0.3, 0.5)

#: Default upper end of the decay-rate bisection (1/s).  Without a gain bound the LMIs of the
#: examples stay feasible for very large sigma with absurd gains (high-gain behaviour), so the
#: search needs a cap; with a gain bound the bound decides.
SIGMA_CAP: float = 100.0

#: Noise-bound design (:mod:`hybobs_opt.lmi.noise_gain`): rates of ``alpha`` on the first, geometric,
#: grid over ``[NOISE_ALPHA_MIN_FRACTION sigma_max, sigma_max]``: nine points over three decades are
#: a factor of 2.4 apart.  On the examples (the scalar oracle, the pendulum, the robot, the vehicle)
#: the bound is unimodal in ``log alpha`` with its minimum between 0.02 and 0.5 of ``sigma_max``, so
#: the golden-section refinement between the best point's neighbours starts in the right bracket.
NOISE_ALPHA_GRID: int = 9

#: Lower end of the noise design's grid as a fraction of the largest decay rate ``sigma_max``: for a
#: fixed gain the bound grows like ``1/sqrt(alpha)`` as ``alpha -> 0`` (the scalar case in closed
#: form), and on the examples the best rate is at least 0.02 ``sigma_max``.
NOISE_ALPHA_MIN_FRACTION: float = 1e-3

#: The golden-section refinement over ``log alpha`` stops when its bracket spans this relative width
#: (1 %): the bound is flat near its minimum (quadratic in ``log alpha``), so the last percent of
#: ``alpha`` changes it by far less than a percent.
NOISE_ALPHA_RTOL: float = 1e-2

#: Largest number of vertices (``2^(r + p_n)``) the polytopic condition is built for; beyond it the
#: problem grows too large to be useful and the hierarchy stops at the multiplier LMIs.
POLYTOPIC_MAX_VERTICES: int = 256

#: Location observer (paper 000): guard on the decay-rate search when no ``max_decay`` is given
#: (1/s): far beyond any sampled implementation, it only stops a diverging search.
LOCATION_DECAY_GUARD: float = 1e7

#: Location observer: iterations of the decay fixed point ``alpha <- log(beta(alpha) Z0 / epsilon)
#: / Delta``; the bound ``beta`` hardly moves with ``alpha`` (it tends to ``||C||``), so 2-4 are
#: the rule.
LOCATION_MAX_DECAY_ITERATIONS: int = 30

#: Positive-observer LP (paper 003): the copositive Lyapunov vectors are bounded to
#: ``1 <= p <= kappa``.  The LP is homogeneous in ``p``, so some bound is needed; this one allows
#: weights over four orders of magnitude (a queue that matters 1e4 times less than another) and
#: keeps Clarabel's 1e-8 accuracy meaningful after the gains ``L = Z / p`` are recovered.
POSITIVE_LP_KAPPA: float = 1e4

#: Positive-observer LP: the bisection on the contraction rate stops when its bracket is narrower
#: than this (rates are reported to three decimals).
POSITIVE_LP_RATE_ATOL: float = 1e-3

#: Gain rule of the sliding-mode observer (paper 001): ``lambda_j = rho * (width of z_{j+1}'s
#: range)`` and ``lambda_n = rho * (width of f's range)``.  The estimate is clipped to the range, so
#: the error ``|e_{j+1}|`` that stage ``j`` must dominate never exceeds that width; ``rho = 1.5``
#: leaves a reaching rate of at least ``(rho - 1) * width`` (Theorem 2's "there exists a choice of
#: lambda_i", made explicit).
SMO_GAIN_MARGIN: float = 1.5

#: A stage of the sliding-mode observer counts as sliding (its anti-peaking switch ``E_j`` of
#: eq. 5 closes) after this many consecutive samples inside its boundary layer
#: ``|e_j| <= h lambda_j``: the first sample inside still carries part of the reaching injection,
#: the equivalent value is exact from the second.
SMO_SLIDING_HOLD: int = 2

#: Default time constant of the sliding-mode observer's low-pass filter of the auxiliary states used
#: for the switching decision, in samples: 20 samples attenuate sample-to-sample noise of the
#: auxiliary states about 6-fold (standard deviation ``~ 1/sqrt(2 * 20)``) for a delay of 20
#: samples (Fig. 5 vs Fig. 6).
SMO_FILTER_STEPS: int = 20

# ---------------------------------------------------------------------- automatic switched-gain design (paper 004)
# (hybobs_opt.lmi.auto_design: settings read from the model for any scalar-nonlinear system;
# each rule is reported with the value, and every value can be given instead.)

#: Scaled gain bound as a multiple of the natural rate ``rho``: the rule of thumb "observer up to
#: ten times faster than the plant", so the gains stay of the size of the model's own numbers
#: instead of growing until the decay-rate cap.
AUTO_DESIGN_GAIN_FACTOR: float = 10.0

#: Minimum decay rate of a grown region as a multiple of ``rho``: regions are grown only as far as
#: their observer still decays at a tenth of the plant's own rate.
AUTO_DESIGN_DECAY_FACTOR: float = 0.1

#: Hysteresis as a fraction of the scheduling range: half a percent keeps the switching from
#: chattering on rounding and noise while hardly shrinking the regions.
AUTO_DESIGN_OVERLAP_FRACTION: float = 0.005

#: Design decay rate as a fraction of each region's largest (as the paper's presets): half the
#: largest rate leaves room for a common Lyapunov matrix across the switches.
AUTO_DESIGN_DECAY_FRACTION: float = 0.5

#: Points of the box where the scaled Jacobian norm is sampled for the natural rate (fixed seed:
#: reproducible): the design needs the rate's size, not its last digit, and a few thousand
#: Jacobian evaluations cost well under a second.
AUTO_DESIGN_RATE_SAMPLES: int = 4000

#: Points of each function's argument interval at which the largest rate of the scheduling
#: coordinate is sampled (:func:`hybobs_opt.lmi.auto_design.max_rate`): 2000 intervals, about
#: twice the resolution of JACOBIAN_BOUND_SAMPLES.
AUTO_DESIGN_RATE_FUNCTION_SAMPLES: int = 2001

#: Design attempts of :func:`~hybobs_opt.lmi.auto_design.design_switched` when the hysteresis does
#: not enforce the dwell time: the design rate fraction is halved (a common ``P`` gets easier,
#: ``tau`` shorter), twice; each is reported under ``dwell_attempts``.
DWELL_RETRY_FRACTIONS: tuple[float, ...] = (0.25, 0.125)

#: ... then the overlap is widened to the required hysteresis times this (a 20 % margin over the
#: hysteresis the dwell-time guarantee needs).
DWELL_RETRY_WIDEN: float = 1.2

# ---------------------------------------------------------------------- switched-gain observer: start and verification

#: Grid of the scheduling coordinate searched by the switched-gain observer's initial-region
#: selection: 720 intervals, one model evaluation each, fine against the regions' widths.
SWITCHED_INIT_GRID: int = 721

#: Grid points of the scheduling coordinate per region of the frozen check
#: (:mod:`hybobs_opt.observers.switched_verification`): 2^5 + 1, dense against the width of a region.
VERIFY_FROZEN_GRID: int = 33

#: At most this many combinations of the other states (the centre plus box corners) per grid point
#: of the frozen check: the centre and 15 corners, every corner of up to three other states and
#: the first 15 beyond, so the check's cost does not double with every state.
VERIFY_MAX_CORNERS: int = 16

#: Default initial errors of the verification runs: this many, each state's error uniform in
#: +- VERIFY_ERROR_FRACTION of the box half-width (seeded; the first one is + VERIFY_ERROR_FRACTION
#: on every state) -- a few, to exercise the switching from different sides at a small cost.
VERIFY_N_INITIAL_ERRORS: int = 4

#: ... and their size: a tenth of the box half-width, a large error for an observer started from a
#: sensible guess.
VERIFY_ERROR_FRACTION: float = 0.1

#: Default convergence tolerance of the verification runs: this fraction of each state's box
#: half-width (the same 1 % as CONVERGENCE_FRACTION).
VERIFY_TOLERANCE_FRACTION: float = 0.01

# ====================================================================== moving-horizon observers (paper 002, eq. 10)

#: Proximal-point passes per window (norm 2): a pass is repeated, centred at its minimiser, only
#: when the minimiser moved away from the warm start (cold starts, mode switches); on noise-free
#: data a second pass always lands on the zero-cost sequence in the tests, a third is a margin.
MHE_PROX_PASSES: int = 3

#: Node QPs the prefix search of one window may solve before the window is left uncertified
#: (``fallback``).  Model (16) needs at most 18 at T = 3.
MHE_CERTIFY_MAX_NODES: int = 20_000

#: Mode sequences that may fit one window within the chi-square threshold before the step is not
#: flagged (``MHEObserver(noise_std=..., arrival_weight="kalman")``, :mod:`hybobs_opt.mhe.mixture`):
#: the stated covariance is the mixture of their posteriors, and a window that more sequences fit is
#: too ambiguous to state one.
MHE_MIXTURE_MAX_SEQUENCES: int = 32

#: Separation of an alternative window-start state in the MHE's uniqueness test, inf-norm in units
#: of the half-widths of X.  Model (16) at T = 3: the weakest observable direction moves the engine
#: speed by 1.9e-4 of its half-range per unit of scaled state, so an alternative 0.05 away costs
#: 8.9e-11 of one sample's squared output half-range, 90 times MHE_UNIQUENESS_COST_RTOL and 15 times
#: the MIQP's bias band; at 0.01 it would be 3.5e-12, inside that band ("unique" then rarely
#: provable), and a larger value would call states 10 % of the box apart "the same".
MHE_UNIQUENESS_DELTA: float = 0.05

#: Largest number of solves of the separated MIQP per window (norm 2): the first, plus the parts
#: searched again after a point within the proximal bias of the threshold (see
#: :meth:`hybobs_opt.mhe.uniqueness.SeparatedProgram.decide`); beyond it the step is a fallback.
MHE_UNIQUENESS_MAX_SOLVES: int = 128

#: DAQP's ``cycle_tol`` for the MHE's branch-and-bound: iterations without objective progress
#: before DAQP reports cycling (exit -2).  DAQP's default of 10 stops 1-6 of 36 noisy windows of
#: 4-mode PWA systems at T = 4-5 in the MIQP of eq. (10) (degenerate big-M vertices take longer
#: non-progress streaks; 20 already cures them) and 13-36 of 36 once the uniqueness MIQP runs
#: too.  With 1000: none on 5 such systems at T = 4 and 5 (a rare true cycle of a warm-started
#: solve is retried on a fresh workspace, see hybobs_opt.mhe.observer); a node that truly cycles
#: still ends after ~1000 iterations as "not certified" (a fallback), never as a wrong answer.
MHE_DAQP_CYCLE_TOL: int = 1000

#: With ``MHEObserver(noise_std=...)``: one minus the level of the confidence region whose extent
#: decides ``observable`` (epsilon = chi2_n^-1(1 - this) of the whitened cost); the same default
#: false-alarm probability as the noise-aware lookup observer.
MHE_NOISE_FALSE_ALARM: float = 1e-3

#: Samples of the noise-consistency test of the arrival prior
#: (:class:`hybobs_opt.mhe.arrival.NoiseConsistencyTest`, the normalised innovations summed):
#: long enough that one unlucky sample does not decide it, short enough that the flags are
#: withdrawn within ten samples of the data contradicting the stated noise level.
CONSISTENCY_WINDOW: int = 10

#: False-alarm probability of one noise-consistency test (the same 1e-3 as MHE_NOISE_FALSE_ALARM).
CONSISTENCY_FALSE_ALARM: float = 1e-3

#: The set-membership observer first enumerates the window's feasible mode sequences (one
#: feasibility MILP each, with no-good cuts) and bounds each by 2n LPs; a window with more than
#: this many times ``n`` sequences goes to the 2n per-state MILPs instead, which then cost less.
#: Model (16), T = 3, 300 steps: 1 x n gives 3.0 / 5.6 / 34 ms per step noise-free / at 1e-3 /
#: at 0.6 rad/s against 8.0 / 8.3 / 28 ms for the per-state MILPs alone (2 x n: 46 ms at 0.6).
SET_MEMBERSHIP_SEQUENCES_PER_STATE: float = 1.0

# ====================================================================== observer contract: samples used, steps flagged

#: A sample whose input or output lies outside the range the model can produce (``input_range``,
#: ``output_range`` of an observer) by more than this fraction of the range's width is not used:
#: it is flagged ``fallback`` and the step is open loop.  Half the width leaves room for sensor
#: noise and offsets while a sensor fault (``y = 1e12``) never enters the state.
RANGE_MARGIN: float = 0.5

#: An estimate outside the model's state set (``state_range`` of an observer) by more than this
#: fraction of the set's width in some coordinate is never flagged ``observable``: the plant cannot
#: be there, so the estimate is wrong by at least that much.  1 % leaves room for the transient
#: overshoot of an observer that has converged and for rounding on the boundary.
STATE_SET_MARGIN: float = 0.01

#: A Luenberger-type observer whose certified error bound ``b`` allows output errors of at most
#: ``b sqrt(C_j P^-1 C_j')`` refuses a sample whose output residual exceeds that by more than this
#: fraction of the output's range width: the sample, or the bound's hypotheses, contradict the
#: model.  The allowance covers what the sampled error bound does not model, the mismatch between
#: a continuous plant and the sampled observer between two samples: on the driveline of paper 000
#: (model output range 5,730 rad/s wide, so an allowance of 5.7 rad/s) the clean runs exceed the
#: bound by at most 6.4e-3 rad/s (hybrid observer; 3.1e-4 with the true locations), while a sensor
#: fault ten times the run's largest output (460 rad/s) exceeds it eighty times over.
INNOVATION_MARGIN: float = 1e-3

#: After this many consecutive samples refused by the innovation test the observer takes the next
#: one and restarts its error bound from the state box: a persistent contradiction is the bound's
#: hypothesis failing (a location switch not yet detected, a model mismatch), not one bad sample.
INNOVATION_PATIENCE: int = 2

#: Noisy data: an observer's fit tolerance of this many output-noise standard deviations
#: (``MHEObserver(fit_tolerance=NOISE_FIT_SIGMAS * std)``); a Gaussian residual exceeds it about
#: once in 1.7 million samples.
NOISE_FIT_SIGMAS: float = 5.0

#: An event-driven observer refuses a time stamp later than the previous accepted one by more than
#: this many times its model's time scale (the timer durations of one cycle): a clock fault
#: (``t = 1e300``) must not move the observer's time reference, after which every good sample
#: would be refused as "before the previous one".  A thousand cycles is no plausible gap in a log.
TIME_JUMP_FACTOR: float = 1000.0

#: An observer flags ``observable`` once its certified error bound is below this fraction of the
#: state set's width in every coordinate (the same 1 % as STATE_SET_MARGIN).
CONVERGENCE_FRACTION: float = 0.01

#: Above this many states the initial error bound uses the box's half-diagonal instead of its 2^n
#: vertices (2^12 = 4096 vertices is still cheap; beyond, the count doubles with every state).
ERROR_BOUND_MAX_VERTEX_STATES: int = 12

#: Hybrid observer (paper 000): vertices of the operating box are enumerated exactly up to this many
#: dimensions (``n + m``), as ERROR_BOUND_MAX_VERTEX_STATES.
HYBRID_OBSERVER_MAX_VERTEX_DIM: int = 12

#: A run of the hybrid observer has "converged" once the transient term ``c e^{-alpha t}
#: ||eps(0)||`` of the bound is below this fraction of ``M0`` (the guaranteed error is then at most
#: 1.01 M0).
TRANSIENT_FRACTION: float = 0.01

#: The Kalman estimate is flagged ``observable`` when its largest standard deviation is below this
#: fraction of the state box's half-width in that coordinate: the data then place the state within
#: 1 % of its range with one-sigma confidence (the default prior, one half-width, is 100 times
#: wider), which is what "reconstructed from the data" means for a stochastic estimate.
KALMAN_OBSERVABLE_STD: float = 0.01

#: Noise-aware lookup observer: default probability that the true mode sequence fails the tests of
#: one window (residual and membership together): about three false alarms in a 3,000-sample run.
NOISE_LOOKUP_FALSE_ALARM: float = 1e-3

#: Set-membership filter: largest number of polytopes kept in the union (the nearest two are merged
#: beyond it): more pieces keep the set tighter, each costs LPs at every step.
SET_FILTER_MAX_PIECES: int = 8

# ====================================================================== benchmarks and the C export

#: At most this many window-start states are classified exactly per bench run (point queries of
#: Definition 2.2, about 1 ms each on model 16 at T = 3 and 17 ms on model 17 at T = 5).
EXACT_LABEL_SAMPLES: int = 300

#: Pivots allowed to one ``B~_T`` LP of the exported C code, per row and column of its tableau
#: (the limit of a piece with ``k`` rows and ``d`` columns is
#: ``C_EXPORT_LP_PIVOTS_PER_LP * (k + d + 2)``).  The LPs of the benchmark scenarios take at most a
#: few pivots per column (model (17), T = 5: see ``benchmarks/results/export.json``); the limit
#: exists so that the worst case of a step is bounded, and an LP that reaches it answers
#: "in ``B~_T``" (conservative).
C_EXPORT_LP_PIVOTS_PER_LP: int = 2

#: Kernel work (calls, weighted per module: NumPy versions 1, loop kernels 10) a process runs with
#: the geometry kernels as Python before it loads their compiled versions (``hybobs_opt._numba_cache``,
#: tiers).  Loading numba and the kernels costs about 0.6 s of CPU once; the Python kernels cost
#: about 8 us more per unit than the compiled ones on small analyses (powertrain3, T = 3: 3,100 units,
#: 8,000 with the first system build) and 36-45 us on large ones (model (17), T = 5 and 6: 177,000 and
#: 405,000 units).  At 20,000 a few small analyses never import numba, and a large one switches
#: within its first tenth, having paid under a second for the wait.
KERNEL_TIER_UP_WORK: int = 20_000
