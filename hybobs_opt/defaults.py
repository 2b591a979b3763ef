"""Named design defaults and budgets.

A default is a value a user could reasonably choose differently: a horizon, a run length, a
bound on a gain or a rate, a grid size, the number of nodes, solves or iterations a search may
spend, a probability of false alarm.  Every such value of the toolbox is defined here with the
reason for its size; most are the default of a keyword argument that overrides them.  Thresholds
that decide a numerical question (rounding, solver accuracy) are in :mod:`hybobs_opt.tolerances`;
refusals of requests too large to run are in :mod:`hybobs_opt.limits`.
"""

# ====================================================================== geometry: exact paths and iteration budgets

#: A degenerate vertex (more than d tight rows) is checked by walking every extreme ray of its
#: cone of feasible directions, found among the null directions of the (d-1)-subsets of its tight
#: rows.  Above this many subsets (e.g. the 32 rows at a vertex of the 6-D cross-polytope give
#: 201,376) the check gives up and the hand-written path answers instead.
VERTEX_DEGENERATE_MAX_SUBSETS: int = 5000

#: Equilibration sweeps of :func:`hybobs_opt.geometry.lp.solve_lp` (rows, then columns, by powers
#: of two, geometric mean of the largest and smallest entry) before every row is set to unit norm.
#: Each sweep about halves the logarithm of the imbalance; 8 sweeps bring states rescaled by 1e6
#: and 1e-6 (entries 1e12 apart within a row, which HiGHS drops below its 1e-9 small-value
#: threshold) within a factor of a few of one, for 4 x 8 small numpy reductions per LP.
LP_EQUILIBRATION_SWEEPS: int = 8

# ====================================================================== sampled checks of a model's functions

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

# ====================================================================== observer design: LMIs, decay-rate searches, gains

#: Bisection on the decay rate sigma and on the dwell time tau stops when the bracket is this
#: fraction of its upper end: 5 % is below the spread between regions, the design uses half the
#: largest rate anyway, and it keeps each search to about 8 solves.
BISECTION_RTOL: float = 5e-2

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

# ====================================================================== moving-horizon observers (paper 002, eq. 10)

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
