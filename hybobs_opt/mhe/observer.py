"""Moving-horizon observer of eq. (10), paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000).

At time ``t`` the observer solves

``min over x(t-T+1)  ||Y_t - Y^_t||``  subject to the PWA dynamics of eq. (1) over the window,

posed on the mixed-logical-dynamical encoding of :mod:`hybobs_opt.mhe.mld`: with the 2-norm
squared it is a mixed-integer quadratic program (MIQP), with the 1- or inf-norm a mixed-integer
linear program (MILP, "Variations of (10) include the use of 1- or inf-norms", Section 4.1).  The
minimiser's window-start state is propagated through the window to give ``x^(t)``.

For noisy data three optional terms follow the moving-horizon estimator of Ferrari-Trecate,
Mignone & Morari (2002), "Moving horizon estimation for hybrid systems", IEEE TAC 47(10):

* an output weight ``W_y``: the cost is ``sum_k ||W_y (y(k) - y^(k))||``;
* state disturbances ``x(k + 1) = f_i(x(k), u(k)) + w(k)`` penalised by ``||W_w w(k)||``;
* an arrival cost ``||W_a (x(t-T+1) - x_bar)||`` where ``x_bar`` is the previous window's estimate
  of the new window-start state (or the ``x0`` of :meth:`MHEObserver.reset` for the first window).

Flags (the runtime contract of :mod:`hybobs_opt.contract`):

* ``observable`` -- the window trajectory is *unique*, the reported current state ``x(t)`` and the
  window start among it: a certified global optimum of (10) (see below) and no other admissible
  window trajectory with a state at least ``delta`` away from the optimum's at the same step
  (inf-norm, in units of the half-widths of ``X``,
  :data:`~hybobs_opt.defaults.MHE_UNIQUENESS_DELTA`) reaches a cost within ``epsilon`` of it (:data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_RTOL` times
  one sample's squared weighted output half-range, with the floor
  :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_ATOL`; norms 1 / inf: the square roots),
  proven by a second, separated mixed-integer program (Notes of :class:`MHEObserver`); ``x`` is
  the minimiser propagated to ``t``.  As Section 4.1 of paper 002 explains, a single minimiser
  cannot tell whether ``x(t-T+1)`` is observable: this second program is what does.  With an
  ``analysis`` (:class:`~hybobs_opt.regions.ObservabilityAnalysis`) its point query at the
  estimate decides instead (Definition 2.2: distinguishable for *every* input sequence, a
  stronger statement than the data-based one).  With ``MHESettings(check_uniqueness=False)`` and
  no analysis the flag means a certified optimum only, not a unique one.
* ``unobservable`` -- either the solver certified that the window has *no* model trajectory in
  ``X`` (infeasible), or the optimum is not unique: ``info["alternative"]`` holds another
  window trajectory (``x_start``, ``states``, ``cost``, ``modes``, ``distance``, and the
  ``step`` where it is farthest) with a state at least ``delta`` away
  whose cost is within ``epsilon`` of the optimum, re-checked in numpy (or the analysis says the
  estimate is unobservable).  The data cannot tell the state: open-loop prediction is used.
* ``fallback`` -- a bad sample, an input outside ``U`` (where the big-M constants are not valid),
  a solve that was not certified (iteration/time limit, numerical failure, failed
  verification, solver exception), or a uniqueness answer that was not certified:
  open-loop prediction, ``info["reason"]`` says why.  Never an exception in the loop.
* ``warming_up`` -- fewer than ``T`` samples so far.

Certified optimum: either the solver's status says optimal and the answer passes a numpy re-check
(finite, integral binaries, one mode per step, every constraint row within tolerance), or a warm
start of zero cost (the cost is nonnegative).  ``info["certified_optimum"]`` says whether the
step had one (``observable`` without the uniqueness test), ``info["cost"]`` is its cost,
``info["gap_bound"]`` an upper bound on ``cost - optimum`` and ``info["solved_by"]`` says how it
was certified; ``info["uniqueness"]`` reports the uniqueness test (``status``, a
:class:`~hybobs_opt.mhe.uniqueness.UniquenessOutcome`; ``decided_by``,
``separated_cost``, ``separated_cost_bound``, ``threshold = J* + epsilon``, ``seconds``).

Solvers.  Norm 2: ``"daqp"`` (default) is DAQP's branch-and-bound on its persistent workspace
(:class:`daqp.Model`, set up once, re-solved with new linear term and bounds each step);
``"casadi-daqp"`` is the same solver through CasADi's ``conic("daqp", {"discrete": ...})`` plugin
(see the Notes of :class:`MHEObserver` for why it is not the default); ``"bonmin"`` is CasADi's
``nlpsol("bonmin")``.  Norms 1 and inf: ``"highs"`` (default) is HiGHS through ``highspy`` (model
passed once, row bounds changed each step); ``"cbc"`` and ``"casadi-highs"`` go through CasADi's
``conic`` with ``discrete`` variables (CasADi's HiGHS plugin and highspy cannot share a process,
see :class:`~hybobs_opt.mhe.backends.highs_backend.HighspyBackend`).  Every problem is built once, with the window data ``U_t, Y_t``
and the arrival prior entering only the linear term and the constraint bounds.  ``"sequences"``
(norms 1 and inf, :mod:`hybobs_opt.mhe.sequence_lp`) solves no mixed-integer program: eq. (10) of
paper 002 in the 1- / inf-norm with the modes fixed is a small LP in the window-start state, and
an exact branch and bound over mode prefixes decides the window with those LPs (matrices
precomputed per prefix, the data entering through precomputed affine maps, lower bounds proven
in numpy by weak duality with any multipliers, DAQP's LP mode with HiGHS as fallback), and
decides the uniqueness of the flag ``observable`` by separated LPs in the same tree.  On the noisy
bench of model (16) at T = 3 it gives the flags of ``"highs"`` at every step at a fraction of the
time (``benchmarks/results/mhe_milp.json``); it refuses an ``extend`` hook.

Formulation.  Eq. (10), its 1- / inf-norm variants and the optional terms are written once in
CasADi (:class:`~hybobs_opt.mhe.formulation.MHEFormulation`: SX expressions of the decision
vector with the window data as parameters); the constraint matrix, the affine dependence of the
bounds and of the linear term on the data, and the cost's Hessian (norm 2) or cost vector (norms
1 / inf) are extracted from it once, at construction, by ``casadi.jacobian`` / ``casadi.hessian``,
and every backend receives those.  An ``extend`` callable adds cost terms, affine constraints and
parameters to the same expressions (:class:`~hybobs_opt.mhe.formulation.MHEExtension`).

Layout.  This module holds the runtime object; :mod:`hybobs_opt.mhe.settings` its solve and
certification settings (:class:`~hybobs_opt.mhe.settings.MHESettings`);
:mod:`hybobs_opt.mhe.formulation` the problem in CasADi; :mod:`hybobs_opt.mhe.window` the model
side of a window (dynamics, cost, the exact problem of one mode sequence), :mod:`hybobs_opt.mhe.residual`
the weights and the stacked residual, :mod:`hybobs_opt.mhe.uniqueness` the separated program,
:mod:`hybobs_opt.mhe.backends` one module per solver family behind one signature and
:mod:`hybobs_opt.mhe.result` the typed answer of a window (:class:`WindowResult`).
``Estimate.info`` is ``WindowResult.to_dict()`` plus the observer's keys (``certified_optimum``,
``uniqueness``, ``alternative``, ``reason``, ``analysis_label``).
"""

from __future__ import annotations

import difflib
import inspect
import logging
import time
from dataclasses import fields, replace
from typing import Any

import numpy as np

from .._deprecation import warn_renamed
from .._logging import verbose_level, verbose_logging
from .._validate import as_positive, as_vector
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, UNOBSERVABLE, WARMING_UP, check_reset_keywords,
                        checked_state, false_alarm_probability, judge_samples_against, noise_std_vector)
from ..defaults import (INNOVATION_MARGIN, MHE_MIXTURE_MAX_SEQUENCES, MHE_NOISE_FALSE_ALARM,
                        NOISE_FIT_SIGMAS)
from ..errors import ModelError
from ..regions.verdicts import PointClass
from ..status import Status
from ..systems.pwa import PWASystem
from ..tolerances import (
    MEMBERSHIP_RTOL,
    MHE_ABS_SUBOPT,
    MHE_ARRIVAL_MIN_STD_RTOL,
    MHE_CERTIFIED_RTOL,
    MHE_FEASIBILITY_TOL,
    MHE_INTEGRALITY_TOL,
    MHE_POLISH_SKIP_TOL,
    MHE_ZERO_COST_RTOL,
)
from .backends import MILP_SOLVERS, MIQP_SOLVERS, milp_backend, miqp_backend
from .formulation import MHEFormulation
from .mixture import sequence_mixture, sequence_posterior_covariance
from .mld import BigMConstants
from .residual import weight_matrix
from .result import WindowResult
from .settings import MHESettings
from .uniqueness import SeparatedProgram, UniquenessOutcome
from .window import WindowModel

__all__ = ["MHEObserver", "NORMS", "SOLVERS"]

NORMS = ("2", "1", "inf")
#: Solvers per norm; the first one is the default.
SOLVERS = {"2": MIQP_SOLVERS, "1": MILP_SOLVERS, "inf": MILP_SOLVERS}


class MHEObserver(Observer):
    """Moving-horizon observer (10) of paper 002 on the runtime observer contract.

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1) with bounded ``X`` and ``U`` (eq. 2).
    T : int
        Window length (``T >= 1``); the paper uses ``T = 3`` for model (16).
    norm : {"2", "1", "inf"}
        ``"2"``: ``||.||_2^2`` of eq. (10) (MIQP); ``"1"`` / ``"inf"``: the MILP variants.
    solver : str, optional
        ``"daqp"`` (default for norm 2), ``"casadi-daqp"``, ``"bonmin"``; ``"highs"`` (default for
        norms 1/inf, via highspy), ``"cbc"`` or ``"casadi-highs"`` (refused when highspy is loaded),
        or ``"sequences"`` (norms 1/inf: the exact mode-prefix branch and bound of small LPs of
        :class:`~hybobs_opt.mhe.sequence_lp.SequenceLPSolver`, no MIP; ``MHESettings(solver_options=
        {"lp": "highs"})`` solves its LPs by HiGHS alone instead of DAQP first).
    output_weight, disturbance_weight, arrival_weight : scalar, vector or matrix, optional
        ``W_y`` (default identity: the paper's cost), ``W_w`` (adds disturbances ``w(k)``),
        ``W_a`` (adds the arrival cost); see the module docstring.  The arrival cost is a prior, and the uniqueness
        program keeps it: with ``W_a`` the flag ``observable`` means unique *given the prior*, not
        determined by the data alone (``info["uniqueness"]["includes_prior"]`` is then ``True``;
        on model (16) with ``W_a = 1e-3`` two of 300 backlash windows were flagged so).
        ``arrival_weight`` may also be an :class:`~hybobs_opt.synthesis.arrival_weight.ArrivalPrior` of
        :func:`~hybobs_opt.synthesis.arrival_weight.certified_arrival_prior`: the weight tuned from the noise
        level (it must have been tuned for this observer's ``noise_std``), which never claims more
        information than a Kalman filter has under any mode sequence (kept as
        :attr:`arrival_prior`).  ``arrival_weight="kalman"`` (norm 2, solver ``"daqp"``, with
        ``noise_std``) is the filtering update of Rao, Rawlings & Lee (2001): a Kalman filter
        (:class:`~hybobs_opt.mhe.arrival.KalmanArrival`) runs behind the window on the samples
        that left it, in the modes the windows' optima gave them, with ``R = noise_std^2`` and
        ``Q = (W_w' W_w)^-1``; each window's prior ``x_bar`` is its prediction of the
        window-start state and ``W_a`` the inverse square root of its covariance, so no sample
        enters both the prior and the window (``info["arrival"]``: the prior, its standard
        deviations and its information matrix ``W_a' W_a``).  The weight changes the MIQP's Hessian
        each window: DAQP's workspace is updated in place, nothing is rebuilt.  Each flagged
        estimate then states its covariance (``info["covariance"]``): the mixture of the Gaussian
        posteriors of every mode sequence whose least cost is within the chi-square threshold
        ``J* + epsilon``, weighted by their evidence, about the estimate
        (:mod:`hybobs_opt.mhe.mixture`, ``info["mixture"]``); a window that more than
        :data:`~hybobs_opt.tolerances.MHE_MIXTURE_MAX_SEQUENCES` sequences fit, or whose search
        stops at the settings' ``certify_max_nodes`` / ``certify_time_budget``, is ``fallback``.
        (On a step not flagged, ``info["covariance"]`` is the optimal sequence's posterior alone.)  It is claimed
        only while the filter's normalised innovations agree with the stated noise level
        (:class:`~hybobs_opt.mhe.arrival.NoiseConsistencyTest`, ``info["noise_consistency"]``):
        an ``observable`` flag is withdrawn (``unobservable``, the optimum kept as the estimate,
        ``info["note"]`` says why) while the test rejects ``noise_std``, and withheld until it has
        tested a full window of samples since the last reset.
    x0 : (n,) array, optional
        Initial guess (open-loop prediction and first arrival prior); default the centre of ``X``.
    settings : MHESettings, optional
        How each window is solved and certified (:class:`~hybobs_opt.mhe.MHESettings`: solver
        options, the MIQP's proximal terms, the zero-cost certificate, the budget of the exact
        prefix search, the uniqueness test); default ``MHESettings()``.  :attr:`settings` holds
        the settings in force, which differ from these where the observer switches one off
        (``check_uniqueness`` under ``noise_bound``, ``zero_cost_certificate`` with an
        extension cost).
    extend : callable, optional
        ``extend(ext)``, called once at construction with a
        :class:`~hybobs_opt.mhe.formulation.MHEExtension` exposing the CasADi symbols of the
        window (states ``x[k]`` in original units, outputs ``y_hat[k]``, inputs ``u[k]``, data
        ``y[k]``, ``x_bar``, binaries ``delta[k]``, disturbances ``w[k]``): it may add cost terms
        (``add_cost``: a convex sum of squares for norm 2, a linear term for norms 1 / inf),
        affine constraints (``add_constraint``) and parameters (``add_parameter``, values per
        step by :meth:`set_parameter`).  They enter the matrices every solver receives, the cost
        of every trajectory, the problems of the mode sequences, the exact prefix search and
        the uniqueness program.  Norms 1 / inf with an extension cost refuse settings with
        ``check_uniqueness=True`` (the separated program's norm-2 bound ``J_1 >= ||r||_2`` does
        not hold for a linear term) and never use the zero-cost certificate (a linear term can
        be negative: the effective settings have ``zero_cost_certificate=False``).

        Example: a pull of the window-start state towards a reference given each step::

            def pull(ext):
                x_ref = ext.add_parameter("x_ref", ext.n)
                ext.add_cost(1e3 * casadi.sumsqr(ext.x[0] - x_ref))

            obs = MHEObserver(plant, 3, extend=pull)
            obs.set_parameter("x_ref", [0.0, 10.0, 10.0])
    big_m : BigMConstants, optional
        Precomputed constants (share them between MHE instances of the same system).
    analysis : ObservabilityAnalysis, optional
        A saved analysis of Algorithm 3.1 for this system and ``T``
        (:func:`hybobs_opt.regions.analyse_observability`).  Its point query
        ``classify(x(t-T+1))`` at the estimate decides the flag: ``"observable"`` /
        ``"unobservable"`` answer Definition 2.2, i.e. for every input sequence, which is
        stronger than the data-based question of the separated program (an ``unobservable``
        state may still be unique for the input actually applied).  For noisy data it
        classifies the estimate, not the data.  When it answers ``"infeasible"`` (the estimate
        lies outside ``X*_T``) the separated program decides (``fallback`` if the settings have
        ``check_uniqueness=False``).

    fit_tolerance : float or (p,) array, optional
        Largest output residual ``|y(k) - y^(k)|`` of the optimum in a window the model is taken to
        fit.  A certified optimum that misses a sample by more proves that no trajectory of the
        model explains the window (a bad sample, or noise above the tolerance): the step is
        ``fallback``.  Default: :data:`~hybobs_opt.defaults.INNOVATION_MARGIN` of each output's
        range over the model, for noise-free data; set it to a few noise standard deviations for
        noisy data (``noise_std`` does).
    noise_std : float or (p,) array, optional
        Standard deviation of white Gaussian output noise, per output (norm 2 only).  The output
        weight becomes ``W_y = diag(1 / noise_std)`` (so ``output_weight`` must be omitted), the
        fit tolerance defaults to :data:`~hybobs_opt.defaults.NOISE_FIT_SIGMAS` ``noise_std``, and
        the uniqueness test's ``epsilon`` becomes the chi-square quantile ``chi2_n^-1(1 - false_alarm)``
        of the whitened cost: ``observable`` then says that the likelihood-ratio confidence region
        ``{x0 : J(x0) <= J* + epsilon}`` of the window-start state, of level ``1 - false_alarm``
        for a linear-Gaussian window, holds no state ``delta`` away from the estimate -- a statistical
        statement about the data, not the noise-free uniqueness of the default ``epsilon``.  Without
        it the default ``epsilon`` (1e-12 of the output scale) calls a noisy optimum unique however
        far the noise moved it.
    false_alarm : float, default 1e-3
        With ``noise_std``: ``1 -`` the level of that confidence region, in (0, 0.5).
    initial_std : float or (n,) array, optional
        With ``arrival_weight="kalman"``: standard deviation of the error of the first prior (the
        ``x0`` of :meth:`reset`), per state; default that of a uniform distribution over the state
        box (``half-width / sqrt(3)``; the default ``x0`` is the box's centre).
    noise_bound : float, sequence or dict, optional
        Bound on each output's noise, in the outputs' units (a number, one per output, or a dict
        by output name; :func:`~hybobs_opt.contract.noise_bound_vector`): the bounded-noise
        model, instead of ``noise_std``.  Each window then also gets the exact box of the states
        consistent with its data under the bound
        (:meth:`~hybobs_opt.mhe.SetMembershipObserver.consistent_box`, MILPs solved to a zero
        gap), and the estimate (the window optimum's last state, or the box's centre when the
        optimum is not certified or lies outside the box) carries ``info["radius"]``: per state,
        the largest distance to a consistent state.  The flag is the radius's: ``observable``
        when every radius is at most the settings' ``uniqueness_delta`` times the half-widths of
        ``X`` (``info["tolerance"]``), ``unobservable`` otherwise (the estimate and its radius are still
        reported), ``fallback`` when the data contradict the bound or a program has no checked
        answer.  It replaces the uniqueness test (noise-free, a radius within the tolerance is
        the same claim; the effective settings have ``check_uniqueness=False``) and cannot be
        combined with ``noise_std``, ``analysis`` or ``fit_tolerance``.
    verbose : bool or int, default False
        Log the windows of :meth:`step`, :meth:`run` and :meth:`solve_window` to standard error:
        ``True`` (INFO) shows each run's summary and every window that is not certified,
        ``logging.DEBUG`` every window (backend, status, how it was solved, seconds); see
        :func:`hybobs_opt._logging.verbose_logging`.
    **kwargs
        Deprecated until hybobs_opt 0.2.0: the fields of :class:`~hybobs_opt.mhe.MHESettings` as
        keywords (``check_uniqueness=False``), each with a ``FutureWarning``, folded into the
        settings; refused together with ``settings``.  Any other keyword is a
        :class:`~hybobs_opt.errors.ModelError` naming it.

    Attributes
    ----------
    settings : MHESettings
        The solve and certification settings in force.

    See Also
    --------
    MHESettings : How each window is solved and certified.
    WindowResult : The answer of one window (:meth:`solve_window`).
    SetMembershipObserver : The bounded-noise variant with certified radii.
    hybobs_opt.observers.LookupObserver : The lookup-table deadbeat observer it is compared with.

    Notes
    -----
    Uniqueness (the flag ``observable``).  After the optimum ``J*`` with window states ``xi_k*``
    (scaled), a second mixed-integer program on the same MLD rows asks for the least cost of a
    window trajectory with ``||xi_k - xi_k*||_inf >= delta`` at some step ``k`` (the window start,
    the reported state ``k = T - 1`` or any between; a state is affine in the MLD variables):
    ``2 n T`` direction binaries with ``sum = 1`` and big-M rows choose the step, coordinate and
    side (the box of ``X`` bounds ``M``).  Separating the window start alone is not enough: a
    rotation can keep a mirror image within ``delta`` at the start and far at the reported state.
    A separated cost within the decision band of the threshold
    (:func:`~hybobs_opt.tolerances.mhe_decision_band`) decides nothing: the step is a
    ``fallback``, whatever the rounding.  It is built once at construction and re-solved per step:

    1. a cheap sufficient test for an *alternative* first: when the optimal mode sequence's own
       least-squares map has a direction whose cost over ``delta`` is below ``epsilon`` (the
       backlash of model (16)), the QP of that sequence with the separation row, one per
       admissible direction; it can never prove uniqueness, which needs every mode sequence;
    2. norm 2: the branch and bound over mode prefixes of :mod:`hybobs_opt.mhe.unique_search`
       (the optimum's node QPs re-used, a closed-form bound per separation direction and, at full
       sequences, a bound without the Hessian, then the exact QP with the separation row), which decides "unique" or a verified
       alternative, and otherwise leaves the decision to
    3. the norm-2 MIQP (DAQP, its own workspace, proximal weight
       :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_PROX_WEIGHT`) with the objective cutoff
       ``J* + epsilon`` widened by the proximal term's largest value over the box (and
       ``abs_subopt``): "infeasible" (every node pruned) proves that each separated state costs
       more than ``J* + epsilon``, so the state is unique; a returned point is re-checked in
       numpy and the QP of its mode sequence and direction re-solved exactly: at most
       ``J* + epsilon`` makes it an ``alternative``; above (within the proximal bias of the
       threshold) that combination is excluded exactly and the rest searched again, by bounds
       on the binaries only, in ``T + 1`` disjoint parts (at most :data:`~hybobs_opt.defaults.MHE_UNIQUENESS_MAX_SOLVES`
       solves, else "not certified").  DAQP's settings are applied before its setup, with
       ``zero_tol`` below the proximal weight: otherwise DAQP treats the nearly singular Hessian
       as singular and silently switches to proximal iterations, whose answers were measured
       to be wrong by 1e-11 of the output scale, ten times epsilon;
    4. norms 1 / inf: the same MIQP is a sufficient bound, since ``J_1 >= ||r||_2`` and
       ``J_inf >= ||r||_2 / sqrt(N)`` (``N`` residual entries): if no separated state has
       ``||r||_2^2 <= thr^2`` (``N thr^2``) the state is unique without the MILP.  Otherwise the
       separated MILP (HiGHS with ``objective_bound`` and ``objective_target`` at
       ``J* + epsilon``) decides: "infeasible", or an optimum whose dual bound exceeds the
       threshold, proves uniqueness; a verified point below it is an alternative.

    A DAQP solve that ends in cycling (exit -2) or at its iteration limit after warm-started
    solves is repeated once on a workspace set up afresh (the only rebuild, never a per-step
    one): the state kept from earlier solves was seen to cycle where a fresh one does not.

    Every point a solver returns passes the same check as the optimum's before it is trusted:
    finite point (and, for DAQP, finite objective and multipliers), integral binaries, one mode
    per step and one direction, every MLD row within tolerance, the separation satisfied; the
    alternative reported is then a model trajectory rebuilt from its window-start state and
    modes, re-checked and costed in numpy.  With an arrival cost the prior is part of the cost:
    "unique" then refers to the regularised problem.

    Warm start and certification, every step (every norm):

    1. The warm start is the previous window's solution shifted by one sample (its last state
       propagated through the model, the new last mode from the guards); after a reset, the model
       simulated from ``x0``.  The problem of its mode sequence is solved exactly (a QP or LP in
       the window-start state and the disturbances, ``WindowModel.polish``); after a reset every
       constant mode sequence is tried too.  The best of these is the incumbent.
    2. If the incumbent's cost is zero (to :data:`~hybobs_opt.tolerances.MHE_ZERO_COST_RTOL`) it
       is optimal, the cost being nonnegative (``solved_by = "warm start"``, unless the
       settings have ``zero_cost_certificate=False``).  On noise-free data this is nearly every
       step.
    3. Otherwise the MIQP/MILP is solved with the incumbent as warm start (DAQP: proximal centre
       and objective cutoff; HiGHS: MIP start).  ``solved_by`` is ``"branch-and-bound"`` when the
       solver's point is returned and ``"branch-and-bound (incumbent)"`` when the solver proves
       that nothing beats the incumbent.  Norm 2: when the MIQP's certificate (``gap_bound``
       below, at least its value at the centre of the variable bounds) exceeds the gap the
       incumbent must prove, the MIQP is not solved and the exact prefix search of
       :mod:`hybobs_opt.mhe.certify` certifies the window (``"warm start, certified by prefix
       search"``, or ``"prefix search"`` when it finds a better sequence).

    DAQP needs a positive-definite Hessian; eq. (10) has none in the binaries and the big-M
    copies.  The MIQP therefore minimises ``J / J_s + eps ||v - v_bar||^2`` with ``v_bar`` the
    incumbent (or warm start), solved in the displacement ``v - v_bar`` so that the objective
    values stay near zero (cost differences of 1e-10 of the output energy separate the mode
    sequences of model (16)).  The returned point's cost exceeds the optimum by at most
    ``gap_bound = J_s (abs_subopt + sum_j eps_j R_j)``, ``R_j`` the largest ``(v_j - v_bar_j)^2``
    over the variable bounds; it is reported, and it is what "certified" means for the MIQP.
    When the minimiser moved away from the centre the MIQP is solved again centred at it
    (proximal-point passes, at most the settings' ``prox_passes``).  With ``polish`` the
    continuous part is then re-solved exactly for the optimal mode sequence, so the estimate
    carries no proximal bias.

    ``"casadi-daqp"`` uses the DAQP copy bundled in CasADi 3.8.2, whose branch-and-bound returns
    NaN with a success status when the problem has equality rows, and wrong points or false
    "infeasible" answers with small curvature on the binaries (found on this encoding); the one-hot
    rows are eliminated for it, and its answers are verified like every other solver's.
    ``"daqp"`` (the ``daqp`` Python package, a newer DAQP) is the default for that reason.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> obs = MHEObserver(plant, 3)                 # MIQP of eq. (10), T = 3, solved by DAQP
    >>> trace = obs.run(U, truth.y)
    >>> trace.flag_counts()
    {'observable': 8, 'unobservable': 0, 'fallback': 0, 'warming_up': 2}
    >>> bool(np.allclose(trace.x_hat[-1], truth.x[-1], atol=1e-6))
    True

    One step at a time, with what the flag means in ``info``:

    >>> obs.reset()
    >>> for u, y in zip(U[:3], truth.y[:3]):
    ...     est = obs.step(u, y)
    ...
    >>> est.flag, est.info["status"], est.info["uniqueness"]["status"]
    ('observable', 'optimal', <UniquenessOutcome.UNIQUE: 'unique'>)
    """

    name = "mhe"

    def __init__(self, system: PWASystem, T: int, norm: str = "2", solver: str | None = None, output_weight=None,
                 disturbance_weight=None, arrival_weight=None, *, x0=None, settings: MHESettings | None = None,
                 big_m: BigMConstants | None = None, analysis=None, fit_tolerance=None, extend=None, noise_std=None,
                 false_alarm: float = MHE_NOISE_FALSE_ALARM, initial_std=None, noise_bound=None,
                 verbose: bool | int = False, **kwargs: Any):
        from .._numba_cache import tier_up

        tier_up()  # the compiled kernels now, not in the middle of a run of steps
        verbose_level(verbose)  # refused before any work when it is not a level
        self.verbose = verbose
        self._set_problem(system, T, norm, solver, analysis)
        self.settings = _settings_in_force(settings, kwargs)
        asked_uniqueness = self.settings.check_uniqueness
        self.noise_std, noise_epsilon = self._noise_model(noise_std, false_alarm, self.norm, output_weight)
        self._bounded = self._bounded_noise(noise_bound, analysis, fit_tolerance)
        if self._bounded is not None:
            self.settings = replace(self.settings, check_uniqueness=False)  # the radius decides the flag
        if self.noise_std is not None:
            output_weight = np.diag(1.0 / self.noise_std)
            if fit_tolerance is None:
                fit_tolerance = NOISE_FIT_SIGMAS * self.noise_std
        self._set_weights(output_weight, disturbance_weight, arrival_weight, initial_std, extend)
        self._formulate(big_m, extend, asked_uniqueness)
        self._build()
        self.model = WindowModel(system, self.T, self.norm, self.enc, self._Wy, self._Ww, self._Wa, res=self._res,
                                 extension=self._ext)
        if self._kalman is not None:
            self._arrival_rows = self._locate_arrival_rows()
        Ub = system.input_bounds
        self._U_A = None if Ub is None else Ub.A
        self._U_b = None if Ub is None else Ub.b + MEMBERSHIP_RTOL * (1.0 + np.abs(Ub.b))
        self._x_default = self.model.cx.copy()
        judge_samples_against(self, system)
        self.fit_tolerance = self._fit_tolerance(fit_tolerance)
        self._build_uniqueness(noise_epsilon)
        self.reset(x0)

    def _set_problem(self, system, T, norm, solver, analysis) -> None:
        """Check and keep the model, the window length, the norm, the solver and the saved analysis."""
        if not isinstance(system, PWASystem):
            raise ModelError("system", "a PWASystem", type(system).__name__)
        if isinstance(T, bool) or not isinstance(T, (int, np.integer)) or T < 1:
            raise ModelError("T", "an integer horizon T >= 1", repr(T))
        norm = str(norm).lower()
        if norm not in NORMS:
            raise ModelError("norm", f"one of {NORMS}", repr(norm))
        solver = SOLVERS[norm][0] if solver is None else str(solver).lower()
        if solver not in SOLVERS[norm]:
            raise ModelError("solver", f"one of {SOLVERS[norm]} for norm {norm!r}", repr(solver))
        if analysis is not None:
            if not callable(getattr(analysis, "classify", None)):
                raise ModelError("analysis", "an ObservabilityAnalysis (hybobs_opt.regions) with classify(x)",
                                 type(analysis).__name__)
            if getattr(analysis, "T", None) != int(T) or not _same_pwa(getattr(analysis, "system", None), system):
                raise ModelError("analysis", f"an analysis of this system at T = {int(T)}",
                                 f"T = {getattr(analysis, 'T', None)} of {getattr(analysis, 'system', None)!r}")
        self.analysis = analysis
        self.system = system
        self.T = int(T)
        self.norm = norm
        self.solver = solver
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = system.state_names
        self.name = f"mhe-{'miqp' if norm == '2' else 'milp'}-{norm}"

    def _set_weights(self, output_weight, disturbance_weight, arrival_weight, initial_std, extend) -> None:
        """The weights ``W_y``, ``W_w``, ``W_a`` of the cost, with the arrival prior or the Kalman
        filter behind the window when ``arrival_weight`` asks for one."""
        self._Wy = weight_matrix(np.eye(self.p) if output_weight is None else output_weight, self.p, "output_weight")
        self._Ww = weight_matrix(disturbance_weight, self.n, "disturbance_weight")
        self.arrival_prior = self._arrival_prior(arrival_weight)
        if self.arrival_prior is not None:
            arrival_weight = self.arrival_prior.weight
        self._kalman = self._kalman_arrival(arrival_weight, initial_std, disturbance_weight, extend)
        if self._kalman is not None:
            # built with W_a = I; each window sets the filter's weight (_set_arrival_weight)
            arrival_weight = np.eye(self.n)
        self._Wa = weight_matrix(arrival_weight, self.n, "arrival_weight")

    def _formulate(self, big_m, extend, check_uniqueness: bool) -> None:
        """Eq. (10) written once in CasADi, with the extension's terms; every matrix of the
        backends is extracted from it.  ``check_uniqueness`` is the value the caller asked for."""
        self.formulation = MHEFormulation(self.system, self.T, self.norm, self._Wy, self._Ww, self._Wa, big_m=big_m,
                                          extend=extend)
        self.enc = self.formulation.enc
        self._ext = self.formulation.extension
        if self._ext is not None and self._ext.cost_vector is not None:
            if check_uniqueness:
                raise ModelError("check_uniqueness", f"False with an extension cost for norm {self.norm!r} (the "
                                 "separated program bounds J_1 / J_inf by ||r||_2, which a linear term breaks)", "True")
            # a linear term can be negative: zero cost proves nothing
            self.settings = replace(self.settings, zero_cost_certificate=False)
        self._params: dict[str, np.ndarray | None] = (
            {} if self._ext is None else dict(zip(self._ext.names, self._ext.defaults)))
        self._theta_idx = np.r_[self.enc.slices["xi0"], self.enc.slices["omega"]]
        self._res = self.formulation.res

    def _build_uniqueness(self, noise_epsilon: float | None) -> None:
        """The separated program of the flag ``observable`` (built only with ``check_uniqueness``;
        its ``epsilon`` always), and the mode-prefix LPs of solver ``"sequences"``."""
        # With an arrival cost the separated program keeps it: "unique" is then unique given the
        # prior, a weaker claim than the data alone (info["uniqueness"]["includes_prior"]).  Posing
        # it on the data alone needs the data-only minimum of each window, a second MIQP per step.
        self.uniqueness_includes_prior = self._Wa is not None
        options = self.settings.solver_options
        self._separated = SeparatedProgram(self.model, self._res, solver=self.solver,
                                           delta=self.settings.uniqueness_delta, Js=self._Js, eq_rows=self._eq_rows,
                                           milp_problem=self._milp, nslack=self._nslack, options=dict(options),
                                           build=self.settings.check_uniqueness, epsilon=noise_epsilon)
        self._sequences = None
        if self.solver == "sequences":
            from .sequence_lp import SequenceLPSolver

            self._sequences = SequenceLPSolver(self.model, self._zero_cost, self._separated,
                                               lp=options.get("lp", "daqp"), tables=options.get("tables", "auto"),
                                               memory_budget=options.get("memory_budget"),
                                               max_lps=self.settings.certify_max_nodes,
                                               time_budget=self.settings.certify_time_budget)
        self.uniqueness_epsilon = self._separated.epsilon
        if self._separated.prox_weight is not None:
            self.uniqueness_prox_weight = self._separated.prox_weight

    def _bounded_noise(self, noise_bound, analysis, fit_tolerance):
        """The set-membership box of ``noise_bound`` (a :class:`~hybobs_opt.mhe.SetMembershipObserver`
        whose :meth:`consistent_box` each window asks), or ``None``."""
        self.noise_bound = None
        if noise_bound is None:
            return None
        if self.noise_std is not None:
            raise ModelError("noise_bound", "omitted when noise_std is given (one noise model: bounded or Gaussian)",
                             "both given")
        if analysis is not None:
            raise ModelError("analysis", "omitted with noise_bound (the radius decides the flag, not the noise-free "
                             "point query)", "an analysis")
        if fit_tolerance is not None:
            raise ModelError("fit_tolerance", "omitted with noise_bound (the data fit the model when the consistent box "
                             "is not empty)", repr(fit_tolerance))
        from .set_membership import SetMembershipObserver

        half = self.system.scales()[0][: self.n]
        box = SetMembershipObserver(self.system, self.T, noise_bound, tolerance=self.settings.uniqueness_delta * half)
        self.noise_bound = box.noise_bound
        return box

    def _bounded_estimate(self, result: WindowResult, info: dict, x_pred: np.ndarray, q_pred: int) -> Estimate:
        """The step under ``noise_bound``: the window's consistent box, the estimate and its radius."""
        box = self._bounded.consistent_box(self._U, self._Y)
        info["seconds_box"] = box["seconds"]
        if box["status"] != "ok":
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, dict(info, reason=box["reason"]))
        lower, upper = box["lower"], box["upper"]
        if result.optimal and np.all((result.states[-1] >= lower) & (result.states[-1] <= upper)):
            x, mode, source = result.states[-1].copy(), int(result.modes[-1]), "window optimum"
        else:
            x, source = 0.5 * (lower + upper), "centre of the consistent box"
            last = {seq[-1] for seq in box["mode_sequences"]}
            mode = last.pop() if len(last) == 1 else -1
        radius = np.maximum(x - lower, upper - x)
        tol = self._bounded.tolerance
        flag = OBSERVABLE if np.all(radius <= tol) else UNOBSERVABLE
        info.update({"radius": radius, "lower": lower, "upper": upper, "tolerance": tol, "estimate_from": source,
                     "mode_sequences": box["mode_sequences"], "box_by": box["box_by"]})
        self._x, self._mode = x, mode
        return Estimate(x.copy(), mode, flag, 0.0, info)

    def _noise_model(self, noise_std, false_alarm, norm: str, output_weight) -> tuple[np.ndarray | None, float | None]:
        """The ``noise_std`` keyword as a ``(p,)`` array and the uniqueness ``epsilon`` it implies (or ``None``s)."""
        self.false_alarm = None
        if noise_std is None:
            return None, None
        if norm != "2":
            raise ModelError("noise_std", "norm '2' (the chi-square confidence region is one of the squared 2-norm)",
                             f"norm {norm!r}")
        if output_weight is not None:
            raise ModelError("output_weight", "omitted when noise_std is given (the weight is 1 / noise_std)",
                             "both given")
        sigma = noise_std_vector(noise_std, self.p)
        from scipy.stats import chi2

        self.false_alarm = false_alarm_probability(false_alarm)
        return sigma, float(chi2.isf(self.false_alarm, self.n))

    def _kalman_arrival(self, value, initial_std, disturbance_weight, extend):
        """The :class:`~hybobs_opt.mhe.arrival.KalmanArrival` of ``arrival_weight="kalman"`` (else ``None``)."""
        from ..synthesis.arrival_weight import std_vector
        from .arrival import KalmanArrival

        if not (isinstance(value, str) and value == "kalman"):
            if initial_std is not None:
                raise ModelError("initial_std", "given only with arrival_weight='kalman'", repr(initial_std))
            return None
        if self.noise_std is None or self.norm != "2" or self.solver != "daqp":
            raise ModelError("arrival_weight", "'kalman' only with norm '2', solver 'daqp' and noise_std (the filter's "
                             "R is noise_std^2; the weight changes the DAQP Hessian each window)",
                             f"norm {self.norm!r}, solver {self.solver!r}, noise_std {self.noise_std}")
        if extend is not None:
            raise ModelError("extend", "None with arrival_weight='kalman'", "an extension")
        half = self.system.scales()[0][: self.n]
        if initial_std is None:
            if not np.all(np.isfinite(half) & (half > 0)):
                raise ModelError("initial_std", "given when the state box is unbounded or flat", repr(half.tolist()))
            s0 = half / np.sqrt(3.0)  # a uniform distribution over the state box
        else:
            s0 = std_vector(initial_std, self.n, "initial_std", "of the first prior's error, per state")
        Q = None
        if disturbance_weight is not None:
            Ww = weight_matrix(disturbance_weight, self.n, "disturbance_weight")
            WtW = Ww.T @ Ww
            if np.linalg.matrix_rank(WtW) < self.n:
                raise ModelError("disturbance_weight", "invertible with arrival_weight='kalman' (Q = (W_w' W_w)^-1)",
                                 "a singular weight")
            Q = np.linalg.inv(WtW)
        self.initial_std = s0
        return KalmanArrival(self.system, self.noise_std, Q, s0, MHE_ARRIVAL_MIN_STD_RTOL * half)

    def _locate_arrival_rows(self) -> slice:
        """The arrival block of the stacked residual, checked to be ``I (x0 - x_bar)`` as built."""
        sl = dict(self._res.blocks).get("arrival")
        xi = self.enc.slices["xi0"]
        hx, cx = self.model.hx, self.model.cx
        res = self._res
        if sl is None or not (np.allclose(res.R[sl][:, xi], np.diag(hx)) and np.allclose(res.SX[sl], -np.eye(self.n))
                              and np.allclose(res.r0[sl], cx)):
            raise ModelError("arrival_weight", "an arrival block W_a (x0 - x_bar) in the formulation", "another layout")
        self._Z = np.eye(self.n)  # the information of the weight the matrices now hold
        return sl

    def _set_arrival_weight(self, L: np.ndarray) -> None:
        """Put ``W_a = L`` into every matrix that holds it: the residual rows, the window model, the
        MIQP's Hessian (DAQP workspace updated in place) and the separated program's."""
        sl, xi = self._arrival_rows, self.enc.slices["xi0"]
        hx, cx = self.model.hx, self.model.cx
        Z = L.T @ L
        dH = 2.0 * (hx[:, None] * (Z - self._Z) * hx[None, :])
        self._Hc[xi, xi] += dH
        self._H[xi, xi] += dH / self._Js
        self._backend.set_hessian(self._H)
        res = self._res
        res.R[sl, xi] = L * hx[None, :]
        res.SX[sl] = -L
        res.r0[sl] = L @ cx
        self.model.Wa = L
        self._Wa = L
        self._Z = Z
        if self._separated.built:
            self._separated.refresh_hessian()

    def _linear_term(self, pvec: np.ndarray, xbar: np.ndarray) -> np.ndarray:
        """Norm 2: the cost's gradient at ``v = 0``; the formulation's, corrected for the arrival
        weight of this window when it changes (the formulation holds ``W_a = I``)."""
        g = self.formulation.linear_term(pvec)
        if self._kalman is None:
            return g
        xi = self.enc.slices["xi0"]
        g = g.copy()
        g[xi] += 2.0 * self.model.hx * ((self._Z - np.eye(self.n)) @ (self.model.cx - xbar))
        return g

    def _state_mixture(self, xbar: np.ndarray, result: WindowResult, info: dict) -> str:
        """The covariance of a flagged window (``arrival_weight="kalman"``): the mixture of the
        posteriors of every mode sequence that fits within the chi-square threshold
        (:func:`~hybobs_opt.mhe.mixture.sequence_mixture`).  Returns the flag: ``observable``, or
        ``fallback`` when the sequences could not all be found (no covariance is then claimed)."""
        budget = self.settings.certify_time_budget
        deadline = None if budget is None else time.perf_counter() + budget
        mix = sequence_mixture(self.model, self._U, self._Y, xbar, result.states[-1],
                               float(result.cost) + float(self.uniqueness_epsilon),
                               max_sequences=MHE_MIXTURE_MAX_SEQUENCES, max_nodes=self.settings.certify_max_nodes,
                               deadline=deadline)
        info["mixture"] = mix.to_dict()
        if not mix.complete:
            info["reason"] = (f"no covariance stated: the mode sequences that fit within the chi-square threshold "
                              f"were not all found ({mix.reason})")
            return FALLBACK
        info["covariance"] = mix.covariance.tolist()
        return OBSERVABLE

    def _arrival_prior(self, value):
        """The ``arrival_weight`` keyword when it is an :class:`~hybobs_opt.synthesis.arrival_weight.ArrivalPrior`
        (checked against this observer's noise level), else ``None``."""
        from ..synthesis.arrival_weight import ArrivalPrior

        if not isinstance(value, ArrivalPrior):
            return None
        if self.noise_std is None or value.noise_std.shape != self.noise_std.shape or not np.allclose(
                value.noise_std, self.noise_std, rtol=1e-12, atol=0.0):
            raise ModelError("arrival_weight", "an ArrivalPrior tuned for this observer's noise_std "
                             f"({None if self.noise_std is None else self.noise_std.tolist()})",
                             f"one tuned for noise_std {value.noise_std.tolist()}")
        if value.information.shape != (self.n, self.n) or not value.verify():
            raise ModelError("arrival_weight", f"a verified ArrivalPrior of a {self.n}-state system",
                             "one that fails its re-check or has another size")
        return value

    def _fit_tolerance(self, value) -> np.ndarray | None:
        """The ``fit_tolerance`` keyword as a ``(p,)`` array (``None``: no output range to derive it from)."""
        if value is None:
            rng = self.output_range
            width = None if rng is None else rng[1] - rng[0]
            if width is None or not np.all(np.isfinite(width)):
                return None
            return INNOVATION_MARGIN * width
        tol = as_vector(value, "fit_tolerance", self.p) if np.ndim(value) else np.full(self.p, as_positive(
            value, "fit_tolerance", "a positive output tolerance (one value, or one per output)"))
        if not np.all(np.isfinite(tol) & (tol > 0)):
            raise ModelError("fit_tolerance", "positive finite output tolerances", f"{tol.tolist()}")
        return tol

    def _misfit(self, result: WindowResult) -> str | None:
        """Why the optimum does not fit the window's outputs within :attr:`fit_tolerance` (``None`` if
        it does): no trajectory of the model fits the data, so a sample of the window is wrong."""
        if self.fit_tolerance is None:
            return None
        ry = np.abs(self.model.output_residuals(result.states, result.modes, self._U, self._Y))
        bad = np.argwhere(~(ry <= self.fit_tolerance[None, :]))
        if not bad.size:
            return None
        k, j = (int(v) for v in bad[0])
        name = self.output_names[j] if j < len(self.output_names) else f"y[{j}]"
        return (f"no trajectory of the model fits the window: the optimum misses {name} at window sample {k} by "
                f"{ry[k, j]:.3g} > fit_tolerance {self.fit_tolerance[j]:.3g} (a bad sample, or noise above it)")

    # ------------------------------------------------------------------ offline
    def _build(self) -> None:
        """The backend on the matrices extracted from the CasADi formulation (once).

        Norm 2: ``H = hessian(cost, v) / J_s + 2 diag(eps)`` (``J_s`` the largest diagonal entry
        of ``R'R``, half the cost Hessian's); norms 1 / inf: the cost vector and rows of the
        MILP in ``z = [v; e]`` (:class:`~hybobs_opt.mhe.formulation.MHEFormulation`).
        """
        enc, form = self.enc, self.formulation
        options = dict(self.settings.solver_options)
        self._eq_rows = enc.lo == enc.hi
        if self.norm == "2":
            Hc = form.hessian
            self._Hc = Hc
            diag = 0.5 * np.diag(Hc)
            self._Js = float(diag.max()) if diag.max() > 0 else 1.0
            self._zero_cost = MHE_ZERO_COST_RTOL * self._Js
            # proximal weights: continuous variables and binaries (see Notes of the class)
            self._eps = np.where(enc.discrete, self.settings.binary_prox_weight, self.settings.prox_weight)
            self._H = Hc / self._Js + 2.0 * np.diag(self._eps)
            self._backend = miqp_backend(self.solver, self._H, enc.A, enc.lb, enc.ub, enc.discrete, self._eq_rows,
                                         enc, options)
            self._milp, self._nslack = None, 0
            return
        # MILP: slacks e >= |r| / js (norm 1: one per residual entry; inf: one per block)
        js = form.js
        self._Js = js
        ns = form.nslack
        self._nslack = ns
        self._zero_cost = np.sqrt(MHE_ZERO_COST_RTOL) * js
        c, A, lb, ub, disc = form.lp_c, form.lp_A, form.lp_lb, form.lp_ub, form.lp_discrete
        self._milp = (c, A, lb, ub, disc)
        if self.solver == "sequences":
            self._backend = None  # the mode-prefix branch and bound of LPs is built after the window model
            return
        self._backend = milp_backend(self.solver, c, A, lb, ub, disc, options, problem=f"MHE observer (norm {self.norm})")

    # ------------------------------------------------------------------ uniqueness programs
    @property
    def _u_miqp(self):
        """The separated MIQP (:attr:`SeparatedProgram.miqp`)."""
        return self._separated.miqp

    @property
    def _u_milp(self):
        """The separated MILP of norms 1 / inf (:attr:`SeparatedProgram.milp`)."""
        return self._separated.milp

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, **kwargs: Any) -> None:
        """Clear the window.

        Parameters
        ----------
        x0 : (n,) array, optional
            Seeds open-loop prediction and the first arrival prior (default: centre of ``X``).
        q0 : int, optional
            Known initial mode: the mode reported until the first open-loop step or window
            decides it (default ``-1``, unknown).  The warm start's modes always come from the
            guards at ``x0``.
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        x0 = checked_state(self._x_default if x0 is None else x0, self.n)
        if q0 is not None and (isinstance(q0, bool) or not isinstance(q0, (int, np.integer))
                               or not 0 <= q0 < self.system.n_modes):
            raise ModelError("q0", f"a mode index in 0..{self.system.n_modes - 1} or None", repr(q0))
        self._x = x0.copy()
        self._mode = -1 if q0 is None else int(q0)
        self._start = x0.copy()  # estimate of the state at the first sample of the coming window
        self._prev: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # (states, modes, last u)
        self._Y = np.zeros((self.T, self.p))
        self._U = np.zeros((self.T, self.m))
        self._count = 0
        self._u_prev: np.ndarray | None = None
        if self._kalman is not None:
            self._kalman.reset(x0)

    def set_parameter(self, name: str, value) -> None:
        """Set an extension parameter (``ext.add_parameter``) for the coming windows.

        The value holds until it is set again (a fixed parameter is one set once).

        Parameters
        ----------
        name : str
            The parameter's name.
        value : array_like
            Its value, of the shape it was declared with.

        Raises
        ------
        ModelError
            If the observer has no such parameter, or the value has the wrong size or is not finite.
        """
        from .formulation import _param_value

        if self._ext is None or name not in self._ext.names:
            raise ModelError("name", f"an extension parameter of this observer ({[] if self._ext is None else list(self._ext.names)})",
                             repr(name))
        sl = self._ext.offsets[self._ext.names.index(name)]
        self._params[name] = _param_value(name, value, (sl.stop - sl.start, 1))

    # ------------------------------------------------------------------ model helpers
    def _open_loop(self, u: np.ndarray | None) -> tuple[np.ndarray, int, bool]:
        """``f_pwa(x(t-1), u(t-1))``; keeps the estimate if it has left ``X x U`` (never raises)."""
        if u is None:
            return self._x, self._mode, False
        q = self.model.mode_at(self._x, u) if self.model.in_X(self._x) else -1
        if q < 0:
            return self._x, self._mode, False
        return self.model.f(self._x, u, q), q, True

    def _shifted(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The previous window's trajectory shifted by one sample and extended by the model."""
        Xp, mp, u_last = self._prev
        X = np.empty_like(Xp)
        modes = np.empty_like(mp)
        X[:-1], modes[:-1] = Xp[1:], mp[1:]
        X[-1] = self.model.f(Xp[-1], u_last, int(mp[-1]))
        q = self.model.mode_at(X[-1], U[-1])
        modes[-1] = mp[-1] if q < 0 else q
        return X, modes

    # ------------------------------------------------------------------ one solve
    def step(self, u, y) -> Estimate:
        """Process one sample ``(u(t), y(t))`` and return the estimate of ``x(t)`` (:meth:`Observer.step <hybobs_opt.contract.Observer.step>`).

        Parameters
        ----------
        u : (m,) array_like
            Input sample.
        y : (p,) array_like
            Output sample.

        Returns
        -------
        Estimate
            The estimate, its mode, flag, compute time and details (``info``: the window's
            :meth:`WindowResult.to_dict <hybobs_opt.mhe.result.WindowResult.to_dict>` and the flag's reasons).
        """
        if not self.verbose:
            return super().step(u, y)
        with verbose_logging(self.verbose):
            return super().step(u, y)

    def run(self, U, Y):
        """Run :meth:`step` over a recorded trace (:meth:`Observer.run <hybobs_opt.contract.Observer.run>`).

        Parameters
        ----------
        U : sequence of (m,) samples
            Inputs, one row per step.
        Y : sequence of (p,) samples
            Outputs, one row per step (same number as ``U``).

        Returns
        -------
        ObserverTrace
            The estimates of every step.
        """
        with verbose_logging(self.verbose):
            t0 = time.perf_counter()
            trace = super().run(U, Y)
            _log.info("MHE run (T = %d, norm %s, solver %s): %d samples in %.3g s, flags %s", self.T, self.norm,
                      self.solver, trace.n_steps, time.perf_counter() - t0,
                      {k: v for k, v in trace.flag_counts().items() if v})
            return trace

    def solve_window(self, U: np.ndarray, Y: np.ndarray, x_start: np.ndarray | None = None,
                     uniqueness: bool = False) -> WindowResult:
        """Solve eq. (10) on one window (no observer state is changed).

        Parameters
        ----------
        U : (T, m) array
        Y : (T, p) array
        x_start : (n,) array, optional
            Warm start and arrival prior for the window-start state (default: centre of ``X``);
            the warm-start mode sequence is simulated from it through the guards.
        uniqueness : bool
            Also run the separated program of the observer's flag on an optimal answer (needs
            ``settings.check_uniqueness``; a saved ``analysis`` is not consulted):
            ``uniqueness`` (and ``alternative`` when one is found), as in :meth:`step`'s ``info``.

        Returns
        -------
        WindowResult
            ``status`` (``"optimal"``, ``"infeasible"``, ``"not certified"``), and when optimal:
            ``x_start`` (window-start estimate), ``states`` (``(T, n)``), ``modes``, ``w``
            (``(T - 1, n)`` disturbances), ``cost`` and ``gap_bound`` (original units), plus the
            solver's details, ``seconds`` and ``residuals``.  It reads like the dict this method
            used to return (``out["status"]``, ``out.get("alternative")``; ``out.to_dict()``).
        """
        if not self.verbose:
            return self._solve_window(U, Y, x_start, uniqueness)
        with verbose_logging(self.verbose):
            return self._solve_window(U, Y, x_start, uniqueness)

    def _solve_window(self, U, Y, x_start, uniqueness: bool) -> WindowResult:
        U = np.asarray(U, dtype=float).reshape(self.T, self.m)
        Y = np.asarray(Y, dtype=float).reshape(self.T, self.p)
        xs = self._x_default if x_start is None else np.asarray(x_start, dtype=float).reshape(self.n)
        Xg, mg = self.model.simulate(xs, U)
        out = self._solve(U, Y, xs, Xg, mg, cold=True)
        if uniqueness and out.optimal:
            if not self.settings.check_uniqueness:
                raise ModelError("uniqueness", "False for an observer built with check_uniqueness=False", "True")
            uq = self._uniqueness(U, Y, xs, out)
            uq["includes_prior"] = self.uniqueness_includes_prior
            alt = uq.pop("alternative") if uq["status"] == UniquenessOutcome.ALTERNATIVE else None
            out = out.replace(uniqueness=uq, alternative=alt)
        return out

    def _solve(self, U: np.ndarray, Y: np.ndarray, x_start: np.ndarray, Xg: np.ndarray, mg: np.ndarray,
               cold: bool = False) -> WindowResult:
        """Certified solve of one window; ``(Xg, mg)`` is the warm start (states and modes).

        Norm 2, warm start first: the QP of the warm start's mode sequence is solved exactly
        (:meth:`~hybobs_opt.mhe.window.WindowModel.polish`).  Its cost is an upper bound of (10); when it is zero (to
        :data:`~hybobs_opt.tolerances.MHE_ZERO_COST_RTOL`) it is also the optimum, since the cost
        is a sum of squares, and no branch-and-bound is needed (``solved_by``).  Otherwise it is
        the incumbent of the branch-and-bound: the proximal term is centred at it and its
        objective prunes every node that cannot beat it.  When the minimiser moved away from the
        centre the MIQP is solved again centred at the new minimiser (proximal-point passes).  The
        lowest-cost certified point is returned, with the MLD residuals at it.
        """
        t0 = time.perf_counter()
        if self._ext is not None:
            missing = [k for k, val in self._params.items() if val is None]
            if missing:
                return WindowResult(Status.NOT_CERTIFIED, solver=self.solver,
                                    reason=f"extension parameter(s) {missing} have no value (MHEObserver.set_parameter)")
            self.model.set_parameters(np.concatenate([self._params[k] for k in self._ext.names])
                                      if self._ext.names else np.zeros(0))
        self._t_window = t0
        bounds = self.enc.bounds(U.reshape(-1))
        out = self._solve_certified(U, Y, x_start, Xg, mg, bounds, cold)
        budget = self.settings.certify_time_budget
        if out.optimal and budget is not None:
            spent = time.perf_counter() - t0
            if spent > budget:
                # certified, but later than the budget allows: a late answer is not used
                out = WindowResult(Status.NOT_CERTIFIED, solver=self.solver, solver_detail=out.solver_detail,
                                   reason=f"time budget of {budget:g} s (certify_time_budget) "
                                          f"exhausted: the optimum was certified after {spent:.3g} s")
        if not out.optimal:
            out = out.replace(seconds=time.perf_counter() - t0)
            _log.info("MHE window: solver %s, status %s, %.3g s: %s", out.solver or self.solver, out.status, out.seconds,
                      out.reason or "no reason given")
            return out
        _log.debug("MHE window: solver %s, status %s, solved by %s, %.3g s", out.solver or self.solver, out.status,
                   out.solved_by, time.perf_counter() - t0)
        model, Uc = self.model, U.copy()  # the observer's window buffer changes in place

        def residuals() -> dict[str, float]:
            return {"mld_rows": model.mld_violation(out.states, out.modes, Uc, out.w, bounds)}
        return out.replace(residual_source=residuals, seconds=time.perf_counter() - t0)

    def _solve_certified(self, U, Y, x_start, Xg, mg, bounds, cold: bool) -> WindowResult:
        if self._sequences is not None:
            try:
                out, self._sequences_ctx = self._sequences.solve(U, Y, x_start)
            except Exception as exc:  # a crashing solver must not stop the observer loop
                return WindowResult(Status.NOT_CERTIFIED, solver=self.solver, reason=f"{type(exc).__name__}: {exc}")
            return out
        model, res = self.model, self._res
        Uf, Yf = U.reshape(-1), Y.reshape(-1)
        lo, hi = bounds
        rp = res.offset(Yf, Uf, x_start, model.params)
        # the parameters p = [U; Y; x_bar; P] of the formulation's affine maps
        rp = (rp, self.formulation.parameter_vector(Uf, Yf, x_start, model.params))
        best, Wg = None, None
        Wzero = np.zeros((max(self.T - 1, 0), self.n))
        candidates = [mg] + ([np.full(self.T, q) for q in range(self.system.n_modes)] if cold else [])
        if model.feasible(Xg, mg, U):
            # the warm start itself (a trajectory of the model) may already fit the data exactly
            cost = model.cost(Xg, mg, U, Y, Wzero, x_start)
            if cost <= self._zero_cost:
                # with the zero-cost certificate the optimum is >= 0, so the gap is at most the cost
                best = WindowResult(Status.OPTIMAL, solver=self.solver, solved_by="warm start", polished=False,
                                    x_start=Xg[0].copy(), states=Xg, modes=mg.copy(), w=Wzero, cost=cost,
                                    gap_bound=cost if self.settings.zero_cost_certificate else np.inf, passes=0)
                if self.settings.zero_cost_certificate:
                    return best
                candidates = []
        # candidate incumbents, solved exactly with their modes fixed: the warm start's mode
        # sequence; after a reset (no previous window) also every constant sequence, since a
        # cold guess is often in the wrong mode
        seen = set()
        for seq in candidates:
            key = tuple(int(q) for q in seq)
            if key in seen:
                continue
            seen.add(key)
            pol = model.polish(seq, U, Y, x_start, Xg[0], np.zeros((max(self.T - 1, 0), self.n)))
            if pol is None:
                continue
            x0i, Wi, Xi = pol
            cost = model.cost(Xi, seq, U, Y, Wi, x_start)
            if best is None or cost < best.cost:
                best = WindowResult(Status.OPTIMAL, solver=self.solver, solved_by="warm start", polished=True,
                                    x_start=x0i, states=Xi, modes=np.array(seq, dtype=int), w=Wi, cost=cost,
                                    gap_bound=np.inf, passes=0)
            if best.cost <= self._zero_cost:
                break
        if best is not None:
            Xg, mg, Wg = best.states, best.modes, best.w
            if best.cost <= self._zero_cost and self.settings.zero_cost_certificate:
                return best.replace(gap_bound=best.cost)  # the optimum is >= 0
        passes = self.settings.prox_passes if self.norm == "2" else 1
        info = None
        if self.norm == "2" and best is not None and self._least_gap_bound() > self._allowed_gap(best.cost):
            # the proximal certificate of any pass is at least its value at the box's centre: it
            # cannot prove the gap of this incumbent or of anything cheaper, so the prefix search
            # certifies the window without the MIQP
            passes = 0
            info = WindowResult(Status.NOT_CERTIFIED, solver=self.solver, solver_detail={
                "status": "not solved (its proximal certificate cannot prove the gap: prefix search)"})
        for k in range(passes):
            info, moved = self._solve_once(U, Y, x_start, Xg, mg, Wg, lo, hi, rp, incumbent=best)
            if info.status == Status.INCUMBENT_OPTIMAL:
                best = best.replace(gap_bound=min(best.gap_bound, info.gap_bound),
                                    solved_by="branch-and-bound (incumbent)", passes=k + 1)
                break
            if not info.optimal:
                break
            info = info.replace(passes=k + 1)
            if best is None or info.cost < best.cost:
                gap = info.gap_bound if best is None else min(info.gap_bound, best.gap_bound)
                best = info.replace(gap_bound=gap)
            else:  # the branch-and-bound found nothing better than the incumbent: it certifies it
                solved_by = "branch-and-bound (incumbent)" if best.solved_by == "warm start" else best.solved_by
                best = best.replace(gap_bound=min(best.gap_bound, info.gap_bound), passes=k + 1, solved_by=solved_by)
            if not moved:
                break
            Xg, mg, Wg = info.states, info.modes, info.w
        if self.norm == "2" and (best is None or not best.gap_bound <= self._allowed_gap(best.cost)):
            # the proximal certificate proves nothing against this optimum's size (noisy data):
            # the exact prefix search certifies it, or finds the optimum the solver missed
            return self._certified_by_search(U, Y, x_start, best, info)
        if best is None or not np.isfinite(best.gap_bound):
            # no certified branch-and-bound: an incumbent alone is not an optimum
            if info is not None and info.status in (Status.INFEASIBLE, Status.NOT_CERTIFIED):
                return info
            return WindowResult(Status.NOT_CERTIFIED, solver=self.solver, reason="no certified solve")
        return best

    def _least_gap_bound(self) -> float:
        """The least :meth:`_gap_bound` over every centre in the variable bounds (norm 2)."""
        enc = self.enc
        return float(self._Js * (self._backend.abs_subopt + float(self._eps @ (0.5 * (enc.ub - enc.lb)) ** 2)))

    def _allowed_gap(self, cost: float | None) -> float:
        """The optimality gap a certified window must prove (norm 2): relative, with the zero-cost floor."""
        return max(MHE_CERTIFIED_RTOL * float(cost), self._zero_cost) if cost is not None and np.isfinite(cost) else 0.0

    def _certified_by_search(self, U, Y, x_start, best: WindowResult | None, info: WindowResult | None) -> WindowResult:
        """The window certified by the prefix search of :mod:`hybobs_opt.mhe.certify` (norm 2)."""
        from .certify import search_sequences

        incumbent = None if best is None else (best.modes, best.cost)
        budget = self.settings.certify_time_budget
        deadline = None if budget is None else self._t_window + budget
        found = search_sequences(self.model, U, Y, x_start, incumbent, rtol=MHE_CERTIFIED_RTOL, atol=self._zero_cost,
                                 max_nodes=self.settings.certify_max_nodes, deadline=deadline, time_budget=budget)
        detail = {**({} if info is None else info.solver_detail),
                  "prefix_search": {"nodes": found.nodes, "seconds": found.seconds, "lower_bound": found.lower_bound,
                                    "improved": found.improved, "certified": found.certified}}
        if not found.certified:
            if found.exhaustive and not np.isfinite(found.cost):
                # every mode prefix proven infeasible: no trajectory of the model meets the window
                return WindowResult(Status.INFEASIBLE, solver=self.solver, solved_by="prefix search",
                                    reason="no mode sequence is feasible (every prefix proven infeasible)",
                                    solver_detail=detail)
            return WindowResult(Status.NOT_CERTIFIED, solver=self.solver, solver_detail=detail,
                                reason=f"optimum not certified to the relative gap {MHE_CERTIFIED_RTOL:g}: {found.reason}"
                                       + ("" if info is None or info.reason is None else f" (branch and bound: {info.reason})"))
        gap = max(found.gap, 0.0)
        if not found.improved:
            return best.replace(gap_bound=min(gap, best.gap_bound), solved_by=f"{best.solved_by}, certified by prefix search",
                                solver_detail={**best.solver_detail, **detail})
        states = self.model.trajectory(found.x0, found.modes, U, found.w)
        return WindowResult(Status.OPTIMAL, solver=self.solver, solved_by="prefix search", polished=True,
                            x_start=found.x0, states=states, modes=found.modes, w=found.w,
                            cost=self.model.cost(states, found.modes, U, Y, found.w, x_start), gap_bound=gap,
                            passes=None if best is None else best.passes, solver_detail=detail)

    def _solve_once(self, U, Y, x_start, Xg, mg, Wg, lo, hi, rp,
                    incumbent: WindowResult | None = None) -> tuple[WindowResult, bool]:
        """One solve of the MIQP/MILP centred at the warm start ``(Xg, mg, Wg)``, verified.

        Returns the result and whether the minimiser moved away from the warm start.  With an
        ``incumbent`` (norm 2) its objective is the branch-and-bound's cutoff; if nothing beats it
        the status is ``INCUMBENT_OPTIMAL``.
        """
        enc, res = self.enc, self._res
        rp, pvec = rp
        Uf = U.reshape(-1)
        vbar = enc.pack(Xg, mg, U, Wg) if self.norm == "2" else None
        cutoff = None
        try:
            if self.norm == "2":
                # linear term in the displacement d = v - vbar (the proximal term is centred at
                # vbar): (H_c vbar + g(p)) / J_s, the cost's gradient at the warm start, with
                # H_c = hessian(cost) and g(p) = gradient(cost) at v = 0 extracted from CasADi
                f = (self._Hc @ vbar + self._linear_term(pvec, x_start)) / self._Js
                if incumbent is not None:
                    if incumbent.states is Xg:  # the centre is the incumbent: d = 0
                        obj = 0.0
                    else:
                        d = enc.pack(incumbent.states, incumbent.modes, U,
                                     incumbent.w if enc.disturbances else None) - vbar
                        obj = 0.5 * d @ self._H @ d + f @ d
                    cutoff = obj + MHE_ABS_SUBOPT * (1.0 + abs(obj))
                out = self._backend.solve(f, lo, hi, vbar, cutoff=cutoff)
                v = out.v
            else:
                start = None
                if incumbent is not None and self.solver == "highs":
                    # the incumbent as the MIP start, with its slacks
                    vi = enc.pack(incumbent.states, incumbent.modes, U, incumbent.w if enc.disturbances else None)
                    ri = np.abs(res.R @ vi + rp) / self._Js
                    e = ri if self.norm == "1" else np.array([ri[sl].max() for _, sl in res.blocks])
                    start = np.concatenate([vi, e])
                epi_hi = self.formulation.epigraph_upper(pvec)
                out = self._backend.solve(None, np.concatenate([lo, np.full(epi_hi.size, -np.inf)]),
                                          np.concatenate([hi, epi_hi]), start=start)
                v = None if out.v is None else out.v[: enc.n_vars]
        except Exception as exc:  # a crashing solver must not stop the observer loop
            return WindowResult(Status.NOT_CERTIFIED, solver=self.solver, reason=f"{type(exc).__name__}: {exc}"), False
        common = {"solver": self.solver, "solved_by": "branch-and-bound", "solver_detail": dict(out.detail)}
        if out.status == Status.INFEASIBLE and incumbent is not None:
            if cutoff is not None and self._backend.cutoff_applied:
                # "infeasible" under the cutoff claims that no node beats the incumbent (a point of
                # the problem).  The claim is not taken on trust: the same problem without the
                # cutoff must return a verified point no better than the incumbent.
                try:
                    check = self._backend.solve(f, lo, hi, vbar)
                except Exception as exc:  # a crashing solver must not stop the observer loop
                    return WindowResult(Status.NOT_CERTIFIED, **common, reason=f"{type(exc).__name__}: {exc}"), False
                cv = check.v
                ok = check.status == Status.OPTIMAL and cv is not None and np.isfinite(cv).all()
                if ok and enc.violation(cv, Uf, bounds=(lo, hi)) <= max(MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL):
                    d = cv - vbar
                    if 0.5 * d @ self._H @ d + f @ d >= obj - MHE_ABS_SUBOPT * (1.0 + abs(obj)):
                        return WindowResult(Status.INCUMBENT_OPTIMAL, gap_bound=self._gap_bound(vbar)), False
                    out, v = check, cv  # the cutoff's "infeasible" was wrong: a better point exists
                    common["solver_detail"] = dict(check.detail, cutoff_claim_refuted=True)
                else:
                    return WindowResult(Status.NOT_CERTIFIED, **common,
                                        reason="the solver's 'no node beats the incumbent' was not confirmed by the "
                                               f"solve without cutoff (status {check.detail.get('status')!r})"), False
            else:
                # without a cutoff "infeasible" contradicts the incumbent, a verified point of the window
                return WindowResult(Status.NOT_CERTIFIED, **common,
                                    reason=f"solver status {out.detail.get('status')!r} (infeasible) "
                                           "for a window with a feasible incumbent"), False
        if out.status != Status.OPTIMAL:
            return WindowResult(out.status, **common, reason=f"solver status {out.detail.get('status')!r}"), False
        viol = enc.violation(v, Uf, bounds=(lo, hi)) if np.isfinite(v).all() else np.inf
        if not (viol <= max(MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL)):
            return WindowResult(Status.NOT_CERTIFIED, **common,
                                reason=f"solution failed verification (violation {viol:.3g})"), False
        v = v.copy()
        v[enc.discrete] = np.round(v[enc.discrete])
        if not (v[enc.discrete].reshape(self.T, -1).sum(axis=1) == 1).all():
            return WindowResult(Status.NOT_CERTIFIED, **common, reason="binaries are not one mode per step"), False
        modes = enc.modes(v)
        polished = False
        # The proximal term biases the estimate only where the solution moved away from the warm
        # start; when it did not, the warm start (a trajectory of the model) is a KKT point of
        # (10) to ~eps * tol.  Only the window-start state and the disturbances count: the
        # trajectory is rebuilt from them through the model, the big-M copies (feasible to the
        # solver's tolerance) are not used.
        theta = self._theta_idx
        moved = self.norm != "2" or not (np.array_equal(modes, mg) and np.max(
            np.abs(v[theta] - vbar[theta]), initial=0.0) <= MHE_POLISH_SKIP_TOL)
        if not moved:
            x0, states = Xg[0].copy(), Xg
            W = np.zeros((max(self.T - 1, 0), self.n)) if Wg is None else Wg
        else:
            x0, W = enc.states(v)[0], enc.disturbance(v)
            states = None
            if self.norm == "2" and self.settings.polish:
                pol = self.model.polish(modes, U, Y, x_start, x0, W)
                if pol is not None:
                    x0, W, states = pol
                    polished = True
            if states is None:
                states = self.model.trajectory(x0, modes, U, W)
        result = WindowResult(Status.OPTIMAL, **common, polished=polished, x_start=x0, states=states, modes=modes,
                              w=W, cost=self.model.cost(states, modes, U, Y, W, x_start),
                              gap_bound=self._gap_bound(vbar), verified_violation=float(viol))
        return result, bool(moved)

    def _gap_bound(self, vbar: np.ndarray | None) -> float:
        """Upper bound on ``cost - optimum`` (original units) of an accepted solution."""
        if self.norm != "2":
            return 0.0
        enc = self.enc
        sub = self._backend.abs_subopt
        return float(self._Js * (sub + float(self._eps @ np.maximum((enc.lb - vbar) ** 2, (enc.ub - vbar) ** 2))))

    def _uniqueness(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, result: WindowResult) -> dict:
        """The uniqueness answer of a certified optimum: the separated program, or with solver
        ``"sequences"`` the separated LPs of :meth:`~hybobs_opt.mhe.sequence_lp.SequenceLPSolver.decide`."""
        if self._sequences is not None:
            return self._sequences.decide(U, Y, xbar, result, self._sequences_ctx)
        return self._separated.decide(U, Y, xbar, result)

    def _decide(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, result: WindowResult, info: dict) -> str:
        """Flag of a certified optimum: the analysis's point query, else the separated program.

        ``info`` (the step's ``Estimate.info``) receives ``analysis_label``, ``uniqueness``,
        ``alternative`` and ``reason``.
        """
        if self.analysis is not None:
            t0 = time.perf_counter()
            try:
                label = str(self.analysis.classify(result.x_start))
            except Exception as exc:  # an LP failure must not stop the observer loop
                label = f"failed ({type(exc).__name__}: {exc})"
            info["analysis_label"] = label
            if label in (PointClass.OBSERVABLE, PointClass.UNOBSERVABLE):
                info["uniqueness"] = {"status": UniquenessOutcome.UNIQUE if label == PointClass.OBSERVABLE
                                      else UniquenessOutcome.NOT_UNIQUE_FOR_EVERY_INPUT,
                                      "decided_by": "analysis (Definition 2.2, every input sequence)",
                                      "seconds": time.perf_counter() - t0}
                return OBSERVABLE if label == PointClass.OBSERVABLE else UNOBSERVABLE  # the point class as a flag
        if not self.settings.check_uniqueness:
            if self.analysis is not None:
                info["reason"] = f"analysis label {info['analysis_label']!r} at the estimate and check_uniqueness=False"
                return FALLBACK
            return OBSERVABLE
        uq = self._uniqueness(U, Y, xbar, result)
        uq["includes_prior"] = self.uniqueness_includes_prior
        if uq["status"] == UniquenessOutcome.ALTERNATIVE:
            info["alternative"] = uq.pop("alternative")
        info["uniqueness"] = uq
        if uq["status"] == UniquenessOutcome.UNIQUE:
            return OBSERVABLE
        if uq["status"] == UniquenessOutcome.ALTERNATIVE:
            return UNOBSERVABLE
        info["reason"] = f"uniqueness not certified: {uq.get('reason', '?')}"
        return FALLBACK

    # ------------------------------------------------------------------ runtime
    def _in_U(self, U: np.ndarray) -> bool:
        return self._U_A is None or bool((U @ self._U_A.T <= self._U_b).all())

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        x_pred, q_pred, ok_pred = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._Y[:-1] = self._Y[1:]
        self._Y[-1] = y
        self._U[:-1] = self._U[1:]
        self._U[-1] = u
        self._count += 1
        self._u_prev = u
        if self._count < self.T:
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, WARMING_UP, 0.0, {"certified_optimum": False})
        # warm start: the previous window's trajectory shifted by one sample (or, for the first
        # window after a reset, the model simulated from the initial guess)
        if self._prev is not None:
            Xg, mg = self._shifted(self._U)
        else:
            Xg, mg = self.model.simulate(self._start, self._U)
        xbar = Xg[0]
        if self._kalman is not None:
            # the filter's prediction of the window-start state from the samples before the window
            xbar = self._kalman.x.copy()
            self._set_arrival_weight(self._kalman.weight())
        if not self._in_U(self._U):
            result = WindowResult(Status.NOT_CERTIFIED, reason="input outside U: the big-M constants do not hold there")
        else:
            result = self._solve(self._U, self._Y, xbar, Xg, mg, cold=self._prev is None)
        info = result.to_dict()
        info["certified_optimum"] = result.optimal
        if self._bounded is not None:
            # the optimum, when there is one, warm-starts the next window whatever the flag
            self._prev = (result.states, result.modes, self._U[-1].copy()) if result.optimal else (Xg, mg, self._U[-1].copy())
            return self._bounded_estimate(result, info, x_pred, q_pred)
        if self._kalman is not None:
            info["arrival"] = {"prior": xbar.tolist(), "std": self._kalman.std().tolist(), "information": self._Z.tolist()}
            # the sample leaving the window enters the filter, in the mode the window's answer gives
            # it (without an answer: the warm start's, the previous answer shifted)
            q_first = int(result.modes[0]) if result.optimal else int(mg[0])
            self._kalman.advance(self._U[0], self._Y[0], q_first)
        if result.optimal:
            states, modes = result.states, result.modes
            # the optimum fits the data whatever the flag: it warm-starts the next window
            self._prev = (states, modes, self._U[-1].copy())
            misfit = self._misfit(result)
            if misfit is not None:
                self._x, self._mode = x_pred, q_pred
                return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, dict(info, reason=misfit))
            flag = self._decide(self._U, self._Y, xbar, result, info)
            if self._kalman is not None:
                info["covariance"] = sequence_posterior_covariance(self.model, result.modes, self._U, self._Y,
                                                                   xbar).tolist()
                if flag == OBSERVABLE:
                    flag = self._state_mixture(xbar, result, info)
                check = self._kalman.consistency.result()
                info["noise_consistency"] = check
                if flag == OBSERVABLE and not (check["consistent"] and check["samples"] >= self._kalman.consistency.window):
                    # the covariance rests on the stated noise level: while the data contradict it, or
                    # too few samples have tested it, the optimum is the estimate but nothing about its
                    # error is claimed
                    self._x, self._mode = states[-1].copy(), int(modes[-1])
                    if check["consistent"] is False:
                        info["note"] = (f"flag withdrawn: the filter's normalised innovations over the last "
                                        f"{check['samples']} samples sum to {check['nis_sum']:.4g} > {check['threshold']:.4g} "
                                        f"(chi-square, false alarm {check['false_alarm']:g}): the data contradict the "
                                        "stated noise level (or the model)")
                    else:
                        info["note"] = (f"flag withheld: the stated noise level is tested on {check['samples']} of the "
                                        f"{self._kalman.consistency.window} samples its test needs since the last reset")
                    return Estimate(self._x.copy(), self._mode, UNOBSERVABLE, 0.0, info)
            if flag == OBSERVABLE:
                self._x, self._mode = states[-1].copy(), int(modes[-1])
                return Estimate(self._x.copy(), self._mode, OBSERVABLE, 0.0, info)
            # not unique (or not certified unique): open-loop prediction
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, flag, 0.0, info)
        # no estimate from the data: the warm start (open-loop prediction) carries on
        self._prev = (Xg, mg, self._U[-1].copy())
        self._x, self._mode = x_pred, q_pred
        flag = UNOBSERVABLE if result.status == Status.INFEASIBLE else FALLBACK
        return Estimate(self._x.copy(), self._mode, flag, 0.0, info)

    def _fallback(self, u, reason: str) -> Estimate:
        x_pred, q_pred, _ = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._x, self._mode = x_pred, q_pred
        # a skipped sample breaks the window: gather T new consecutive samples, starting from the
        # open-loop prediction of the next state
        self._u_prev = u
        self._count = 0
        self._prev = None
        nxt, _, ok = self._open_loop(u)
        self._start = nxt.copy() if ok else self._x.copy()
        if self._kalman is not None:
            self._kalman.reset(self._start)  # the filter restarts with the window, from the first prior's spread
        return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, {"reason": reason, "certified_optimum": False})


_log = logging.getLogger(__name__)


def _settings_in_force(settings: MHESettings | None, deprecated: dict[str, Any]) -> MHESettings:
    """The observer's settings: ``settings``, or the deprecated knob keywords folded into
    :class:`MHESettings` (one ``FutureWarning`` each).  Any other keyword is refused."""
    knobs = [f.name for f in fields(MHESettings)]
    unknown = sorted(k for k in deprecated if k not in knobs)
    if unknown:
        known = [k for k in inspect.signature(MHEObserver).parameters if k != "kwargs"] + knobs
        close = difflib.get_close_matches(unknown[0], known, n=1)
        hint = ""
        if close:
            spelt = f"settings=MHESettings({close[0]}=...)" if close[0] in knobs else f"{close[0]}=..."
            hint = f" (did you mean {spelt}?)"
        raise ModelError(f"MHEObserver({unknown[0]}=...)", "a keyword of MHEObserver (the solve and certification "
                         "settings are the fields of settings=MHESettings(...))", f"the keyword {unknown[0]!r}{hint}")
    for name in deprecated:
        # the caller's line: this function, MHEObserver.__init__, then the caller
        warn_renamed(f"MHEObserver({name}=...)", f"MHEObserver(settings=MHESettings({name}=...))", stacklevel=4)
    if settings is None:
        return MHESettings(**deprecated)
    if not isinstance(settings, MHESettings):
        raise ModelError("settings", "an MHESettings (hybobs_opt.mhe) or None", type(settings).__name__)
    if deprecated:
        raise ModelError("settings", f"settings=MHESettings(...) or the deprecated keywords {sorted(deprecated)}, "
                         "not both", "both given")
    return settings


def _same_pwa(a, b) -> bool:
    """Whether two PWA systems have the same modes, guards and bounds (array for array)."""
    if a is b:
        return True
    if not (isinstance(a, PWASystem) and isinstance(b, PWASystem)) or a.n_modes != b.n_modes:
        return False
    if (a.n, a.m, a.p) != (b.n, b.m, b.p):
        return False

    def same(x, y) -> bool:
        return np.shape(x) == np.shape(y) and np.array_equal(x, y)

    for ma, mb in zip(a.modes, b.modes):
        if not all(same(getattr(ma, k), getattr(mb, k)) for k in ("A", "B", "a", "C", "D", "c")):
            return False
        if not (same(ma.guard.A, mb.guard.A) and same(ma.guard.b, mb.guard.b)):
            return False
    for Pa, Pb in ((a.state_bounds, b.state_bounds), (a.input_bounds, b.input_bounds)):
        if (Pa is None) != (Pb is None) or (Pa is not None and not (same(Pa.A, Pb.A) and same(Pa.b, Pb.b))):
            return False
    return True
