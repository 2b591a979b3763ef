"""The lookup-table deadbeat observer, Algorithm 4.1 of paper 002.

Offline (from the saved result of Algorithm 3.1): for every region ``P_i`` with ``i`` in ``I``
the pseudo-inverse ``C_i^+`` of eq. (13), and the region's H-representation rewritten over the
data window ``z = [Y_t; U_t]``.  Because the candidate ``x_i = C_i^+ (Y_t - D_i U_t - f_i)`` is
affine in ``z``, the candidates of eq. (13), their output residuals (the equality of eq. 12) and
the membership tests ``[x_i; U_t] in P_i`` of eq. (14) are *one* matrix product with a
precomputed table followed by reductions.

Online, per step: the set ``chi`` of consistent candidates (eq. 14); if it holds exactly one
state and that state is not in ``B~_T`` (eq. 15), the state at the window start is reconstructed
(flag ``observable``) and propagated to the current time through the region's affine map;
otherwise the observer predicts open loop from its previous estimate (step 2.1, flag
``unobservable``).  ``fallback`` is kept for bad samples (NaN/Inf, wrong length, an input outside
``U``) and for steps without any prediction; every one carries its reason (``Estimate.info``,
``LookupTrace.reasons()``).

Boundaries.  The regions of the paper are not closed: when the true shaft enters the backlash,
the data force the contact sequence's candidate exactly onto the guard boundary, which belongs to
the backlash sequence.  The membership test is therefore strict (by ``LOOKUP_INTERIOR_MARGIN``) on
every row of ``P_i`` that involves the state.  Rows that only bound the inputs (the copies of
``U`` for each step, zero ``x``-part in scaled coordinates and equal to a row of
``system.input_bounds``) are closed (``<= LOOKUP_INPUT_BOUND_TOL``): nothing lies beyond ``U``,
and an input resting on its bound (zero engine torque) is an ordinary sample.  A sample whose
input leaves ``U`` by more than that tolerance is a bad sample.

The ``B~_T`` test (``variant="table"``).  ``B~_T`` is the union of the projections
``Proj_x(R_ij)``, ``i`` in ``I``, ``j`` not in ``I``: a *state-based* test (for all inputs, as in
Definition 2.2).  Two ways to evaluate it, measured on the scenarios of ``hybobs observe``
(3,000 steps, noise-free; shared 2-core machine, so times are +-50 %):

* ``b_tilde="project"``: exact projections offline (:func:`reduced_unobservable_polytopes`),
  then a solver-free point-in-union test online (2-5 us per step).  Model (16), T = 3: 48 pieces
  in 4.5 s.  Model (17), T = 5: the projections alone take minutes (tens of thousands of HiGHS
  LPs for the images' bounding boxes and the iterative hulls), and a thin piece whose
  bounding-box LP HiGHS calls infeasible makes one fail.  Out of reach.
* default, ``b_tilde=None`` ("pairs"): each ``R_ij`` is kept as its H-representation
  (``PairSet.G, g, E, e``), restricted offline to the subspace of its output equalities and
  parameterised by ``x`` (:class:`_PairPieces`); online, the compiled kernel screens the
  candidate against every piece without LPs (the rows that involve ``x`` only, the equalities'
  consistency rows, cuts cached from earlier LPs), and one small certified LP
  (:func:`_max_margin`, 5 variables at T = 5) decides each piece that survives, stopping at the
  first piece that holds ``x``.  Every LP that excludes ``x`` also yields a cut valid for the
  whole piece (weak duality), so the next windows, whose states are close, are screened out
  without an LP.  Model (16), T = 3: tables in 0.05 s, no LP at all in 3,000 steps (2-5 us per
  step).  Model (17), T = 5: tables in 0.5-1.6 s (0.4 s of it
  ``ObservabilityAnalysis.reduced_pairs_all_dimensions``), 976 LPs in 862 of the 1,581 windows
  with a unique candidate, 114 cuts; 3,000 steps in 0.4-0.7 s.  The flags are those of the exact
  projections wherever those could be computed (model 16 at T = 3; model 17 at T = 5 with the
  778-piece pair set) and those of :meth:`ObservabilityAnalysis.classify` on every window.

The ``"exact"`` variant asks the data's own question instead -- is any other mode sequence of
``M \\ I`` consistent with these ``U_t, Y_t`` for a different state? -- with an output-residual
screen and one small LP per rank-deficient region that passes it; it needs no ``B~_T``.  Model
(17), T = 5: tables in 0.1 s, 2,571 LPs, 3,000 steps in 1.5 s, and 717 windows flagged
observable against the table's 719: its residual screen (``output_rtol`` times ``|Y|``, 3e-6
rad/s here) lets a backlash sequence whose outputs differ by 4e-7 rad/s count as consistent, so
the data-based answer is the more conservative one on these data.  The default stays the
paper's state-based test: cheaper, and its flags say the same thing whatever the input.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import FrozenInstanceError, dataclass

import numpy as np

from ..geometry._reproducible import dot, matmul as mm, nnls, norm, numerical_rank, pinv, row_norms, svd
from .._validate import as_instance, as_items, as_positive
from ..errors import ModelError
from ..geometry.lp import solve_slack_lp
from ..geometry.polytope import Polytope
from ..tolerances import (
    LOOKUP_INPUT_BOUND_TOL,
    LOOKUP_INTERIOR_MARGIN,
    LOOKUP_MEMBERSHIP_TOL,
    LOOKUP_OUTPUT_RTOL,
    LOOKUP_SAME_STATE_TOL,
    NEAR_ACTIVE_TOL,
    RANK_RTOL,
    SLACK_CAP,
    ZERO_ROW_TOL,
)
from . import _lookup_kernels as K
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, UNOBSERVABLE, WARMING_UP,
                        check_reset_keywords, checked_state, NONFINITE_SAMPLE, real_sample_pair, sample_rows)

#: Texts of the reason codes of :mod:`._lookup_kernels` (``Estimate.info``, :meth:`LookupTrace.reasons`).
REASONS = {
    K.REASON_NONE: "",
    K.REASON_NONFINITE: NONFINITE_SAMPLE,
    K.REASON_INPUT_OUTSIDE_U: "input outside the input set U (beyond LOOKUP_INPUT_BOUND_TOL): the model does not cover it",
    K.REASON_PREVIOUS_BAD: "not reconstructed, and no open-loop prediction: the previous sample was bad",
    K.REASON_PREDICTION_OUTSIDE: "not reconstructed, and no open-loop prediction: the estimate lies in no mode's region of X x U",
    K.REASON_BAD_SHAPE: "sample of the wrong length or not numeric",
    K.NOTE_CLIPPED: "open-loop prediction clipped to the state bounds",
}

#: Cuts kept per piece of ``B~_T`` (the most recent ones; see :class:`_PairPieces`).
PAIR_CUTS_PER_PIECE = 8


@dataclass(frozen=True, eq=False)
class LookupTrace(ObserverTrace):
    """:class:`ObserverTrace` with the lookup observer's per-step reason codes.

    ``reason_codes[k]`` is a code of :data:`REASONS`: why step ``k`` is ``fallback``, or a note
    (``"open-loop prediction clipped to the state bounds"``) on an ``unobservable`` step.

    Parameters
    ----------
    x_hat, mode, flags, seconds, state_names, observer, info
        As for :class:`ObserverTrace`.
    reason_codes : (N,) int array or None
        The codes above.

    See Also
    --------
    LookupObserver.run : Returns one.
    REASONS : The reason codes.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> trace = LookupObserver(analysis).run(U, truth.y)
    >>> type(trace).__name__, trace.x_hat.shape
    ('LookupTrace', (40, 3))
    >>> trace.flags[:3]
    array(['warming_up', 'warming_up', 'observable'], dtype=object)
    >>> trace.reasons()[:3]
    array(['', '', ''], dtype=object)
    """

    reason_codes: np.ndarray | None = None

    def reasons(self) -> np.ndarray:
        """Per step the reason text (``""`` where there is none).

        Returns
        -------
        ndarray
            Per step the reason text (``""`` where there is none).
        """
        codes = np.zeros(self.n_steps, dtype=int) if self.reason_codes is None else self.reason_codes
        return np.array([REASONS[int(c)] for c in codes], dtype=object)

    def fallback_reasons(self) -> dict[str, int]:
        """How many ``fallback`` steps have each reason.

        Returns
        -------
        dict
            How many ``fallback`` steps have each reason.
        """
        sel = self.flags == FALLBACK
        out: dict[str, int] = {}
        for text in self.reasons()[sel]:
            out[text] = out.get(text, 0) + 1
        return out


class LookupObserver(Observer):
    """Algorithm 4.1 of paper 002 on the common observer contract.

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        Result of Algorithm 3.1 (``hybobs_opt.regions``), e.g. from ``load_analysis(file)``.
    b_tilde : None, "project" or sequence of Polytope
        How ``B~_T`` (eq. 15) is tested (``variant="table"``; see the module docstring):
        ``None``, the pair sets ``R_ij`` with screened certified LPs (offline cost: restrictions
        only); ``"project"``, exact projections offline and a solver-free test online; or the
        H-representations over ``x`` of its pieces.
    variant : {"table", "exact"}
        ``"table"``: the paper's test against ``B~_T``; ``"exact"``: LPs on the data (see module).
    output_rtol : float
        Relative tolerance of the output equality of eq. (12) (raise it for noisy data).
    progress : callable, optional
        ``progress(done, total)`` while the pieces of ``B~_T`` are prepared.

    See Also
    --------
    hybobs_opt.analyse_observability : The analysis it reads (Algorithm 3.1).
    NoiseAwareLookupObserver : The same tables for noisy outputs.
    export_lookup_c : The observer as C99.
    hybobs_opt.mhe.MHEObserver : The moving-horizon observer of the same paper.

    Examples
    --------
    The deadbeat lookup-table observer of paper 002 recovers the state exactly once a window of
    ``T`` samples is in:

    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> obs = LookupObserver(analysis)
    >>> trace = obs.run(U, truth.y)
    >>> trace.flag_counts()
    {'observable': 38, 'unobservable': 0, 'fallback': 0, 'warming_up': 2}
    >>> float(np.abs(trace.x_hat[2:] - truth.x[2:]).max()) < 1e-6
    True
    """

    name = "lookup"

    def __init__(self, analysis, *, b_tilde: Sequence[Polytope] | str | None = None, variant: str = "table",
                 output_rtol: float = LOOKUP_OUTPUT_RTOL, progress: Callable[[int, int], None] | None = None):
        from .._numba_cache import tier_up

        tier_up()  # the compiled kernels now, not in the middle of a run of steps
        from ..regions.observability import ObservabilityAnalysis  # lazy: regions sits beside observers

        as_instance(analysis, "analysis", ObservabilityAnalysis,
                    "an ObservabilityAnalysis (Algorithm 3.1, hybobs_opt.regions; e.g. load_analysis(file))")
        if not isinstance(variant, str) or variant not in ("table", "exact"):
            raise ModelError("variant", "'table' or 'exact'", repr(variant))
        output_rtol = as_positive(output_rtol, "output_rtol", "a positive tolerance")
        if isinstance(b_tilde, str):
            if b_tilde != "project":
                raise ModelError("b_tilde", "None, 'project' or a sequence of polytopes over x", repr(b_tilde))
        elif b_tilde is not None:
            b_tilde = as_items(b_tilde, "b_tilde", Polytope, "polytopes (Polytope) over x")
        if progress is not None and not callable(progress):
            raise ModelError("progress", "None or a callable progress(done, total)", f"{progress!r} of type {type(progress).__name__}")
        self.analysis = analysis
        self.system = analysis.system
        self.variant = variant
        self.output_rtol = output_rtol
        self.T = analysis.T
        self.n, self.m, self.p = self.system.n, self.system.m, self.system.p
        self.state_names = self.system.state_names
        self.name = "lookup" if variant == "table" else "lookup-exact"
        t0 = time.perf_counter()
        self._build_tables()
        self._pairs: _PairPieces | None = None
        self._exact: _ExactTest | None = None
        if variant == "exact":
            self.btilde_test = "none (data LPs)"
            self._build_btilde([])
            self._exact = _ExactTest(analysis, self.output_rtol)
        elif b_tilde is None:
            self.btilde_test = "pairs"
            self._build_btilde([])
            self._pairs = _PairPieces.cached(analysis, progress)
        else:
            self.btilde_test = "polytopes"
            pieces = reduced_unobservable_polytopes(analysis) if isinstance(b_tilde, str) else list(b_tilde)
            self._build_btilde(pieces)
        self.table_seconds = time.perf_counter() - t0
        # One whole step() on a sample without output (a fallback: open-loop prediction from the box
        # centre, no B~_T test, nothing learnt), then a fresh reset: the user's first step runs on
        # warm code (in a fresh process the first step costs about twice the second without it).
        # This class's own methods, so that a
        # subclass's step() is not called before its constructor has run.
        LookupObserver.reset(self)
        LookupObserver.step(self, np.ascontiguousarray(self.analysis.enumeration.centre[self.n:self.n + self.m], dtype=float),
                            self._nan_y)
        self.reset()

    # ------------------------------------------------------------------ offline tables
    def _build_tables(self) -> None:
        an = self.analysis
        n, T, p, m = self.n, self.T, self.p, self.m
        self.I = np.array(an.index_set, dtype=int)
        if self.I.size == 0:
            raise ModelError("analysis", "at least one region with rank C_i = n (the set I of Algorithm 3.1)",
                             "none: no state is observable with this horizon")
        scale, centre = an.enumeration.scale, an.enumeration.centre
        sx = scale[:n]
        self._sx = sx
        d = p * T + m * T
        blocks_x, blocks_r, blocks_m, thr = [], [], [], []
        off_x, off_r, off_m = [], [], []
        starts = []
        row = 0
        self._last = []
        for i in self.I:
            reg = an.regions[i]
            Cp = pinv(reg.C)  # eq. (13)
            Q = np.eye(p * T) - mm(reg.C, Cp)  # residual of the output equality (12)
            # x_i = Cp Y - Cp D U - Cp f
            blocks_x.append(np.hstack([Cp, -mm(Cp, reg.D)]))
            off_x.append(-mm(Cp, reg.f))
            blocks_r.append(np.hstack([Q, -mm(Q, reg.D)]))
            off_r.append(-mm(Q, reg.f))
            # [x_i; U] in P_i  <=>  Hx (Cp Y - Cp D U - Cp f) + HU U <= h, rows unit in scaled coordinates
            Hx, HU = reg.H[:, :n], reg.H[:, n:]
            rn = row_norms(reg.H * scale[None, :])
            rn = np.where(rn > 0, rn, 1.0)
            HxCp = mm(Hx, Cp)
            Mi = np.hstack([HxCp, HU - mm(HxCp, reg.D)]) / rn[:, None]
            mi = (reg.h + mm(HxCp, reg.f)) / rn
            blocks_m.append(Mi)
            off_m.append(-mi)
            closed = input_bound_rows(reg.H, reg.h, self.system, T, scale, centre)
            thr.append(np.where(closed, LOOKUP_INPUT_BOUND_TOL, -LOOKUP_INTERIOR_MARGIN))
            starts.append(row)
            row += Mi.shape[0]
            self._last.append((reg.Phi_last, reg.Gamma_last, reg.phi_last, reg.sequence[-1]))
        K_ = self.I.size
        self._K = K_
        self._nx, self._nr = K_ * n, K_ * p * T
        self._table = np.ascontiguousarray(np.vstack(blocks_x + blocks_r + blocks_m))
        self._offset = np.concatenate(off_x + off_r + off_m)
        self._mthr = np.ascontiguousarray(np.concatenate(thr))
        self._mstarts = np.array(starts + [row], dtype=np.int64)
        self._d = d
        # the input set U, rows unit in scaled input coordinates (bad-sample test)
        if m and self.system.input_bounds is not None:
            IA, Ib = self.system.input_bounds.A, self.system.input_bounds.b
            inrm = row_norms(IA * scale[None, n : n + m])
            inrm = np.where(inrm > 0, inrm, 1.0)
            self._in_A, self._in_b = np.ascontiguousarray(IA / inrm[:, None]), np.ascontiguousarray(Ib / inrm)
        else:
            self._in_A, self._in_b = np.zeros((0, max(m, 1))), np.zeros(0)
        lo, hi = self.system.state_bounds.bounding_box()
        self._x_lo, self._x_hi = np.ascontiguousarray(lo, dtype=float), np.ascontiguousarray(hi, dtype=float)

    def _build_btilde(self, pieces: Sequence[Polytope]) -> None:
        sx = self._sx
        rows, rhs, starts = [], [], []
        r = 0
        for k, P in enumerate(pieces):
            if P.dim != self.n:
                raise ModelError(f"b_tilde[{k}]", f"a polytope over the {self.n} states", f"dimension {P.dim}")
            rn = row_norms(P.A * sx[None, :])
            rn = np.where(rn > 0, rn, 1.0)
            rows.append(P.A / rn[:, None])
            rhs.append(P.b / rn)
            starts.append(r)
            r += P.n_constraints
        self.b_tilde = tuple(pieces)
        self._bt_A = np.ascontiguousarray(np.vstack(rows)) if rows else np.zeros((0, self.n))
        self._bt_b = np.ascontiguousarray(np.concatenate(rhs)) if rhs else np.zeros(0)
        self._bt_starts = np.array(starts + [r], dtype=np.int64)

    def _build_kernel_args(self) -> None:
        sysm = self.system
        table, rhs, starts = sysm._mode_table
        self._modeA = np.ascontiguousarray(np.stack([md.A for md in sysm.modes]))
        self._modeB = np.ascontiguousarray(np.stack([md.B for md in sysm.modes]))
        self._modea = np.ascontiguousarray(np.stack([md.a for md in sysm.modes]))
        self._guard = np.ascontiguousarray(table)
        self._guard_rhs = np.ascontiguousarray(rhs)
        self._guard_starts = np.append(starts, table.shape[0]).astype(np.int64)
        self._Pl = np.ascontiguousarray(np.stack([l[0] for l in self._last]))
        self._Gl = np.ascontiguousarray(np.stack([l[1] for l in self._last]))
        self._pl = np.ascontiguousarray(np.stack([l[2] for l in self._last]))
        self._last_mode = np.array([l[3] for l in self._last], dtype=np.int64)
        mode = {"polytopes": 1, "pairs": 2}.get(self.btilde_test, 0)
        self._ints = np.array([self.T, self._nx, self._nr, self.p * self.T, mode, 1], dtype=np.int64)
        self._ints_bad = self._ints.copy()
        self._ints_bad[5] = 0
        self._reals = np.array([self.output_rtol, LOOKUP_SAME_STATE_TOL, LOOKUP_MEMBERSHIP_TOL, LOOKUP_INPUT_BOUND_TOL])
        self._tables = (self._table, self._offset, self._mthr, self._mstarts, self._sx, self._bt_A, self._bt_b,
                        self._bt_starts, self._Pl, self._Gl, self._pl, self._last_mode,
                        self._modeA, self._modeB, self._modea, self._guard, self._guard_rhs, self._guard_starts,
                        self._in_A, self._in_b, self._x_lo, self._x_hi)
        pp = self._pairs if self._pairs is not None else _PairPieces.empty(self.n)
        self._m_last = self._mstarts[:-1].copy()
        self._tables += (pp.ex_A, pp.ex_b, pp.ex_starts, pp.cut_A, pp.cut_b, pp.cut_count, np.ascontiguousarray(pp.cx),
                         pp.survivors, pp.ex_last, self._m_last)
        self._nan_u = np.full(self.m, np.nan)
        self._nan_y = np.full(self.p, np.nan)
        self._pack(pp)

    def _pack(self, pp: "_PairPieces") -> None:
        """Copy the tables and the state into two contiguous arrays, ``_F`` (float) and ``_I`` (int).

        The compiled step then takes four arguments instead of ~40 (see
        ``_lookup_kernels.FLOAT_SEGMENTS``).  Every attribute that held a table or a piece of the
        state (``_table``, ``_Ybuf``, ``_meta``, the pieces' cuts ...) becomes a view into the
        packed arrays, so the Python parts (the ``B~_T`` LPs and their cuts, ``c_export``) read
        and write the same memory as the kernel.
        """
        T, n, m, p = self.T, self.n, self.m, self.p
        floats = {"reals": self._reals, "table": self._table, "offset": self._offset, "mthr": self._mthr,
                  "sx": self._sx, "bt_A": self._bt_A, "bt_b": self._bt_b, "Pl": self._Pl, "Gl": self._Gl,
                  "pl": self._pl, "mode_A": self._modeA, "mode_B": self._modeB, "mode_a": self._modea,
                  "guard": self._guard, "guard_rhs": self._guard_rhs, "in_A": self._in_A, "in_b": self._in_b,
                  "x_lo": self._x_lo, "x_hi": self._x_hi, "ex_A": pp.ex_A, "ex_b": pp.ex_b, "cut_A": pp.cut_A,
                  "cut_b": pp.cut_b, "x_c": pp.cx,
                  "Ybuf": np.zeros((T, p)), "Ubuf": np.zeros((T, m)), "xcur": np.zeros(n), "uprev": np.zeros(m),
                  "z": np.zeros(T * (p + m)), "xs0": np.zeros(n), "xnew": np.zeros(n)}
        ints = {"ints": self._ints, "meta": np.zeros(7, dtype=np.int64), "mstarts": self._mstarts,
                "bt_starts": self._bt_starts, "last_mode": self._last_mode, "guard_starts": self._guard_starts,
                "ex_starts": pp.ex_starts, "cut_count": pp.cut_count, "survivors": pp.survivors,
                "ex_last": pp.ex_last, "m_last": self._m_last}
        header = np.zeros(K.HEADER, dtype=np.int64)
        f_size = 0
        for k, name in enumerate(K.FLOAT_SEGMENTS):
            a = np.asarray(floats[name], dtype=float)
            header[4 * k : 4 * k + 1 + a.ndim] = (f_size, *a.shape)
            f_size += a.size
        i_size = K.HEADER
        for k, name in enumerate(K.INT_SEGMENTS, start=len(K.FLOAT_SEGMENTS)):
            a = np.asarray(ints[name])
            header[4 * k : 4 * k + 1 + a.ndim] = (i_size, *a.shape)
            i_size += a.size
        F = np.zeros(f_size)
        I = np.zeros(i_size, dtype=np.int64)
        I[: K.HEADER] = header
        views = {}
        for k, name in enumerate(K.FLOAT_SEGMENTS):
            a = np.asarray(floats[name], dtype=float)
            v = F[header[4 * k] : header[4 * k] + a.size].reshape(a.shape)
            v[...] = a
            views[name] = v
        for k, name in enumerate(K.INT_SEGMENTS, start=len(K.FLOAT_SEGMENTS)):
            a = np.asarray(ints[name])
            v = I[header[4 * k] : header[4 * k] + a.size].reshape(a.shape)
            v[...] = a
            views[name] = v
        self._F, self._I = F, I
        (self._reals, self._table, self._offset, self._mthr, self._sx, self._bt_A, self._bt_b, self._Pl, self._Gl,
         self._pl, self._modeA, self._modeB, self._modea, self._guard, self._guard_rhs, self._in_A, self._in_b,
         self._x_lo, self._x_hi) = (views[k] for k in K.FLOAT_SEGMENTS[:19])
        self._ints, self._mstarts, self._bt_starts, self._last_mode, self._guard_starts = (
            views["ints"], views["mstarts"], views["bt_starts"], views["last_mode"], views["guard_starts"])
        pp.ex_A, pp.ex_b, pp.cut_A, pp.cut_b = views["ex_A"], views["ex_b"], views["cut_A"], views["cut_b"]
        pp.ex_starts, pp.cut_count, pp.survivors = views["ex_starts"], views["cut_count"], views["survivors"]
        pp.ex_last, self._m_last = views["ex_last"], views["m_last"]
        self._Ybuf, self._Ubuf, self._xcur, self._uprev, self._z, self._xs0, self._xnew = (
            views[k] for k in ("Ybuf", "Ubuf", "xcur", "uprev", "z", "xs0", "xnew"))
        self._meta = views["meta"]
        self._tables = (self._table, self._offset, self._mthr, self._mstarts, self._sx, self._bt_A, self._bt_b,
                        self._bt_starts, self._Pl, self._Gl, self._pl, self._last_mode,
                        self._modeA, self._modeB, self._modea, self._guard, self._guard_rhs, self._guard_starts,
                        self._in_A, self._in_b, self._x_lo, self._x_hi,
                        pp.ex_A, pp.ex_b, pp.ex_starts, pp.cut_A, pp.cut_b, pp.cut_count, views["x_c"], pp.survivors,
                        pp.ex_last, self._m_last)
        # One call of each compiled entry point now, with nothing to do (a too long u; no rows), so the
        # first step of a process does not pay numba's first dispatch (~0.1 ms): the tables are
        # built here anyway.  The state is untouched.
        K.step_packed(np.zeros(m + 1), self._nan_y, 1, F, I)
        K.run_packed(np.zeros((0, m)), np.zeros((0, p)), 0, F, I, np.zeros((0, n)), np.zeros(0, dtype=np.int64),
                     np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs) -> None:
        """Clear the window; ``x0`` (default: centre of the state box) seeds open-loop prediction.

        Parameters
        ----------
        x0 : (n,) array, optional
            Seed of open-loop prediction (default: the centre of the state box).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        if not hasattr(self, "_tables"):
            self._build_kernel_args()
        if x0 is None:
            x0 = self.analysis.enumeration.centre[: self.n]
        x0 = checked_state(x0, self.n)
        # in place: the state lives in the packed arrays (see _pack)
        self._xcur[:] = x0
        self._meta[:] = (0, -1, 0, 0, -1, 0, 0)
        for buf in (self._Ybuf, self._Ubuf, self._uprev, self._z, self._xs0, self._xnew):
            buf[...] = 0.0

    # ------------------------------------------------------------------ online
    def _decide_candidate(self) -> int:
        """Flag code of a step the kernel left undecided (``CANDIDATE_CODE``): the LP part of the test."""
        if self._exact is not None:
            unobservable = self._exact.other_state_consistent(self._z)
        else:
            unobservable = self._pairs.decide(self._xs0, int(self._meta[6]))
        if unobservable:
            pred_ok = int(self._meta[5]) not in (K.REASON_PREVIOUS_BAD, K.REASON_PREDICTION_OUTSIDE)
            return K.UNOBSERVABLE_CODE if pred_ok else K.FALLBACK_CODE
        k = int(self._meta[4])
        K.propagate_last(k, self._xs0, self._z, self.p * self.T, self._Pl, self._Gl, self._pl, self._xcur)
        self._meta[1] = self._last_mode[k]
        self._meta[5] = K.REASON_NONE
        return K.OBSERVABLE_CODE

    def _advance(self, u: np.ndarray, y: np.ndarray, good: bool) -> int:
        """One compiled step on samples of the right lengths (``good=False``: a malformed one); the flag code."""
        r = K.step_packed(u, y, 1 if good else 0, self._F, self._I)
        code = r & 7
        if code == K.CANDIDATE_CODE:
            code = self._decide_candidate()
        return code

    def step(self, u, y) -> Estimate:
        """Algorithm 4.1 for one sample (compiled); a bad sample gives a ``fallback`` step with its reason.

        ``Estimate.seconds`` is the wall time of the whole call up to the building of the
        estimate (checks, kernel, ``B~_T`` LPs, the copy of the state).  A float64 1-D array
        (e.g. a row of a C-ordered ``(N, m)`` array) goes straight to the compiled kernel; any other
        sample is first checked and converted (:func:`~hybobs_opt.contract.real_sample_pair`).

        Parameters
        ----------
        u : (m,) array_like
            Input sample.
        y : (p,) array_like
            Output sample.

        Returns
        -------
        Estimate
            The estimate, its flag and, in ``info``, the reason of a non-observable step.
        """
        t0 = _perf_counter()
        if type(u) is _ndarray and type(y) is _ndarray:
            try:
                r = _step_packed(u, y, 1, self._F, self._I)
            except TypeError:  # not float64, not 1-D, not contiguous or read-only: the checked path
                r = K.BAD_LENGTH
            if r >= 0:
                code = r & 7
                if code == _OBSERVABLE_CODE or code == _WARMING_CODE:  # no reason, no note: the common steps
                    est = _new_estimate(_StepEstimate)
                    _set_fields(est, (_copy(self._xcur), (r >> 3) - 1, _FLAG_NAMES[code], _perf_counter() - t0, {}))
                    return est
                if code == _CANDIDATE:
                    code = self._decide_candidate()
                    mode = int(self._meta[1])
                else:
                    mode = (r >> 3) - 1
                return _step_estimate(self._xcur.copy(), mode, _FLAG_NAMES[code], self._info(code), t0)
        return self._checked_step(u, y, t0)

    def _checked_step(self, u, y, t0: float) -> Estimate:
        """:meth:`step` for a sample that is not two float64 vectors the kernel takes as they are."""
        checked = real_sample_pair(u, y, self.m, self.p)
        reason = checked if isinstance(checked, str) else ""
        uu, yy = (self._nan_u, self._nan_y) if reason else checked
        code = self._advance(np.ascontiguousarray(uu), np.ascontiguousarray(yy), not reason)
        return _step_estimate(self._xcur.copy(), int(self._meta[1]), _FLAGS[code], self._info(code, reason), t0)

    def _info(self, code: int, reason: str = "") -> dict:
        rc = int(self._meta[5])
        if code == K.FALLBACK_CODE:
            return {"reason": reason or REASONS[rc], "reason_code": rc}
        if rc == K.NOTE_CLIPPED and code == K.UNOBSERVABLE_CODE:
            return {"note": REASONS[rc]}
        return {}

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        return self.step(u, y)

    def _fallback(self, u, reason: str) -> Estimate:
        code = self._advance(self._nan_u, self._nan_y, False)
        return Estimate(self._xcur.copy(), int(self._meta[1]), _FLAGS[code], 0.0, self._info(code, reason))

    def run(self, U, Y, x0: np.ndarray | None = None, progress: Callable[[int, int], None] | None = None) -> LookupTrace:
        """Algorithm 4.1 over a recorded trace, from a reset state (compiled loop).

        Rows with NaN/Inf, or with an input outside ``U``, are bad samples (flag ``fallback``).
        ``seconds`` holds the mean time per step of the whole run; ``reason_codes`` says why each
        ``fallback`` step fell back (:meth:`LookupTrace.reasons`).  ``progress(done, total)`` is
        called every few hundred steps.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.
        x0 : (n,) array, optional
            Seed of open-loop prediction (see :meth:`reset`).
        progress : callable, optional
            ``progress(done, total)``.

        Returns
        -------
        LookupTrace
            The estimates, flags and reason codes of every step.
        """
        t_start = time.perf_counter()
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        if U.shape != (Y.shape[0], self.m) or Y.shape[1] != self.p:
            raise ModelError("U, Y", f"arrays of shapes (N, {self.m}) and (N, {self.p})", f"{U.shape} and {Y.shape}")
        self.reset(x0)
        N = U.shape[0]
        xs = np.empty((N, self.n))
        modes = np.empty(N, dtype=np.int64)
        codes = np.empty(N, dtype=np.int64)
        reasons = np.zeros(N, dtype=np.int64)
        t = 0
        chunk = 250 if progress else N
        while t < N:
            stop = min(N, t + chunk)
            t = K.run_packed(U[:stop], Y[:stop], t, self._F, self._I, xs, modes, codes, reasons)
            if t < stop:  # a candidate whose B~_T test needs LPs
                codes[t] = self._decide_candidate()
                reasons[t] = self._meta[5]
                xs[t], modes[t] = self._xcur, self._meta[1]
                t += 1
            if progress and (t == stop or t == N):
                progress(t, N)
        per_step = (time.perf_counter() - t_start) / max(N, 1)
        flags = np.array([_FLAGS[c] for c in range(5)], dtype=object)[codes]
        return LookupTrace(xs, modes, flags, np.full(N, per_step), self.state_names, self.name, reason_codes=reasons)

    def stats(self) -> dict:
        """Offline time and, for the pair test, the LP/screen counters of the online ``B~_T`` tests.

        Returns
        -------
        dict
            Offline time and, for the pair test, the LP/screen counters of the online ``B~_T``
            tests.
        """
        out = {"table_seconds": self.table_seconds, "btilde_test": self.btilde_test, "n_regions_I": int(self._K)}
        if self._pairs is not None:
            out.update(self._pairs.stats())
        if self._exact is not None:
            out.update(self._exact.stats())
        if self.btilde_test == "polytopes":
            out["n_btilde_pieces"] = len(self.b_tilde)
        return out


_FLAGS = {K.OBSERVABLE_CODE: OBSERVABLE, K.UNOBSERVABLE_CODE: UNOBSERVABLE, K.FALLBACK_CODE: FALLBACK,
          K.WARMING_CODE: WARMING_UP, K.CANDIDATE_CODE: UNOBSERVABLE}


class _StepEstimate(Estimate):
    """The :class:`~hybobs_opt.contract.Estimate` that :meth:`LookupObserver.step` returns.

    The same fields, read-only, in one slot (a tuple ``(x, mode, flag, seconds, info)``): built
    with one slot store instead of the frozen dataclass's five ``object.__setattr__`` or an
    instance dictionary, a few hundred nanoseconds of a step that otherwise takes about one
    microsecond.  ``repr`` (which names it ``Estimate``), equality between two of them,
    ``dataclasses.fields`` / ``asdict`` / ``replace``, copying, pickling and the refusal of any
    assignment behave as for :class:`Estimate`.
    """

    __slots__ = ("_fields",)

    def __init__(self, x, mode: int, flag: str, seconds: float, info: dict | None = None):
        _set_fields(self, (x, mode, flag, seconds, {} if info is None else info))

    x = property(lambda self: self._fields[0], doc="State estimate at the current time.")
    mode = property(lambda self: self._fields[1], doc="Estimated mode (``-1`` when unknown).")
    flag = property(lambda self: self._fields[2], doc="One of :data:`~hybobs_opt.contract.FLAGS`.")
    seconds = property(lambda self: self._fields[3], doc="Wall time of the step.")
    info = property(lambda self: self._fields[4], doc="The reason of a ``fallback`` step, or a note.")

    def __repr__(self) -> str:
        x, mode, flag, seconds, info = self._fields
        return f"Estimate(x={x!r}, mode={mode!r}, flag={flag!r}, seconds={seconds!r}, info={info!r})"

    def __reduce__(self):
        return (_StepEstimate, self._fields)

    def __setattr__(self, name: str, value) -> None:
        raise FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name: str) -> None:
        raise FrozenInstanceError(f"cannot delete field {name!r}")


_new_estimate = object.__new__
_set_fields = _StepEstimate._fields.__set__


def _step_estimate(x: np.ndarray, mode: int, flag: str, info: dict, t0: float) -> _StepEstimate:
    """The estimate of a step that started at ``time.perf_counter() == t0`` (``seconds`` taken last)."""
    est = _new_estimate(_StepEstimate)
    _set_fields(est, (x, mode, flag, _perf_counter() - t0, info))
    return est


# step()'s fast path: names bound once (each global or attribute lookup costs tens of nanoseconds)
_perf_counter = time.perf_counter
_ndarray = np.ndarray
_copy = np.ndarray.copy
_step_packed = K.step_packed
_CANDIDATE = K.CANDIDATE_CODE
_OBSERVABLE_CODE, _WARMING_CODE = K.OBSERVABLE_CODE, K.WARMING_CODE
_FLAG_NAMES = tuple(_FLAGS[c] for c in range(len(_FLAGS)))


def _max_margin(G: np.ndarray, g: np.ndarray, radius_bound: float, threshold: float, problem: str):
    """Largest uniform margin ``t`` (capped) with ``G v + t <= g``, rows taken as given, certified.

    The rows are those of a set whose constraints were unit-norm in scaled coordinates before the
    state was fixed and the set restricted to its output equalities, so ``t`` is the margin by
    which a point lies inside every original constraint (no renormalisation of the restricted
    rows, which would amplify a row that is nearly constant on the subspace).  Solved by
    :func:`hybobs_opt.geometry.lp.solve_slack_lp` (DAQP, both bounds certified, HiGHS when undecided).
    Returns ``(value, w)``: ``value`` decides ``t > threshold`` correctly.
    """
    k, d = G.shape
    A = np.zeros((k + 1, d + 1))
    A[:k, :d] = G
    A[:, d] = 1.0
    bu = np.append(g, SLACK_CAP)
    res = solve_slack_lp(A, bu, radius_bound, threshold, problem)
    return (res.lower if res.lower > threshold else res.upper), res.w


def input_bound_rows(H: np.ndarray, h: np.ndarray, system, T: int, scale: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Which rows of a region ``H [x; U] <= h`` (over ``(x(0), U)``) only bound an input: a row of ``U``.

    A row qualifies when, in scaled coordinates, its ``x``-part is zero (below
    :data:`~hybobs_opt.tolerances.ZERO_ROW_TOL` of the row's norm), its ``U``-part lives in one
    step ``k``, and together with its right-hand side it is a positive multiple of a row of
    ``system.input_bounds`` (the domain rows ``u(k) in U`` that the mode enumeration adds at every
    step).  A guard row that only involves ``u`` is not one of them unless it coincides with a
    bound of ``U``; it stays a guard (strict).

    Parameters
    ----------
    H : (k, n + T m) ndarray
        Rows of the region over ``(x(0), U)``.
    h : (k,) ndarray
        Right-hand side.
    system : PWASystem
        The system (its ``input_bounds``).
    T : int
        Window length (samples).
    scale, centre : (n + T m,) ndarray
        Scaling of ``(x(0), U)`` (half-widths and centre, as in the mode enumeration).

    Returns
    -------
    (k,) bool ndarray
        ``True`` for the rows that only bound an input.

    See Also
    --------
    LookupObserver : Uses it to accept inputs on the boundary of ``U``.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import input_bound_rows
    >>> region = analysis.regions[0]
    >>> lo, hi = plant.state_bounds.bounding_box()
    >>> rows = input_bound_rows(region.H, region.h, plant, 3, np.r_[(hi - lo) / 2, np.ones(3)],
    ...                         np.r_[(hi + lo) / 2, np.zeros(3)])
    >>> rows.dtype, rows.shape == region.h.shape
    (dtype('bool'), True)
    """
    n, m = system.n, system.m
    out = np.zeros(H.shape[0], dtype=bool)
    if m == 0 or system.input_bounds is None or H.shape[0] == 0:
        return out
    Hs = H * scale[None, :]
    hs = h - mm(H, centre)
    rn = row_norms(Hs)
    xn = row_norms(Hs[:, :n])
    IA, Ib = system.input_bounds.A, system.input_bounds.b
    su, cu = scale[n : n + m], centre[n : n + m]
    IAs = IA * su[None, :]
    inrm = np.maximum(row_norms(IAs), np.finfo(float).tiny)
    IAs, Ibs = IAs / inrm[:, None], (Ib - mm(IA, cu)) / inrm
    for r in np.nonzero((rn > 0) & (xn <= ZERO_ROW_TOL * rn))[0]:
        blocks = Hs[r, n:].reshape(T, m) / rn[r]
        active = np.nonzero(row_norms(blocks) > ZERO_ROW_TOL)[0]
        if active.size != 1:
            continue
        a, b = blocks[active[0]], hs[r] / rn[r]
        if np.any((row_norms(IAs - a[None, :]) <= ZERO_ROW_TOL * 10) & (np.abs(Ibs - b) <= ZERO_ROW_TOL * 10 * (1 + np.abs(b)))):
            out[r] = True
    return out


class _PairPieces:
    r"""The pieces ``Proj_x(R_ij)`` of ``B~_T`` without projections: a point test per piece.

    For a pair set ``R_ij`` over ``w = (x, x^, U)`` (scaled, rows unit) with the output
    equalities ``E_x x + E_w (x^, U) = e``, fixing ``x`` leaves ``(x^, U) = w_0(x) + N v``
    (``w_0`` affine in ``x``, ``N`` the nullspace of ``E_w``), the consistency rows
    ``Q (e - E_x x) = 0`` when ``E_w`` has no full row rank (a flat piece), and rows
    ``A v <= b_0 + B_1 x``.  Rows with ``A_k = 0`` only involve ``x``.  ``x`` is in the piece
    (closed, tolerance ``LOOKUP_MEMBERSHIP_TOL``) iff the consistency and ``x``-only rows hold
    and ``max_v min_k (b_0 + B_1 x - A v)_k >= -tol``: one LP, certified (:func:`_max_margin`).

    When the LP excludes ``x``, multipliers ``lam >= 0, sum lam = 1`` on its active rows (NNLS)
    bound the margin at *every* ``x'``: ``t(x') <= lam'(b_0 + B_1 x') + R |A' lam|`` (weak
    duality; ``R`` bounds ``|v|`` on the piece), so ``{x' : lam'(b_0 + B_1 x') + R |A' lam| < -tol}``
    is outside the piece: a cut, cached and screened without LPs in the next windows.
    """

    def __init__(self, analysis, progress: Callable[[int, int], None] | None = None):
        from ..regions.enumeration import horizon_scaling

        system, T = analysis.system, analysis.T
        n, m = system.n, system.m
        self.n = n
        pairs = analysis.reduced_pairs_all_dimensions()
        scale, centre = horizon_scaling(system, T, copies_of_x=2)
        self.sx, self.cx = scale[:n], centre[:n]
        tol = LOOKUP_MEMBERSHIP_TOL
        # |v| <= |(x^, U)| on the piece (w_0 is orthogonal to N), and (x^, U) is in the box up to tol
        self.radius = float(np.sqrt(n + m * T) * (1.0 + 10 * tol))
        ex_rows, ex_rhs, ex_starts = [], [], [0]
        self.lp = []  # per piece: (A, b0, B1) of the rows that involve v
        self.ij = []
        for k, pair in enumerate(pairs):
            if progress and (k % 50 == 0 or k + 1 == len(pairs)):
                progress(k + 1, len(pairs))
            G = pair.G * scale[None, :]
            g = pair.g - mm(pair.G, centre)
            gn = np.maximum(row_norms(G), np.finfo(float).tiny)
            G, g = G / gn[:, None], g / gn
            E = pair.E * scale[None, :]
            e = pair.e - mm(pair.E, centre)
            en = np.maximum(row_norms(E), np.finfo(float).tiny)
            E, e = E / en[:, None], e / en
            Gx, Gw, Ex, Ew = G[:, :n], G[:, n:], E[:, :n], E[:, n:]
            Uu, S, Vt = svd(Ew) if Ew.shape[0] else (np.zeros((0, 0)), np.zeros(0), np.eye(Ew.shape[1]))
            r = numerical_rank(S, RANK_RTOL)
            # consistency rows  Q (e - Ex x) = 0  (left nullspace of Ew)
            Q = Uu[:, r:].T
            Qx, q0 = -mm(Q, Ex), mm(Q, e)
            qn = row_norms(Qx)
            const = qn <= ZERO_ROW_TOL
            if np.any(np.abs(q0[const]) > tol):
                continue  # the outputs can never be equal: an empty piece
            Qx, q0 = Qx[~const] / qn[~const, None], q0[~const] / qn[~const]
            # particular solution w0(x) = P0 + P1 x, nullspace N
            Ur, Sr, Vr = Uu[:, :r], S[:r], Vt[:r].T
            P0 = mm(Vr, mm(Ur.T, e) / Sr)
            P1 = -mm(Vr, mm(Ur.T, Ex) / Sr[:, None])
            N = np.ascontiguousarray(Vt[r:].T)
            A = mm(Gw, N)
            b0 = g - mm(Gw, P0)
            B1 = -(Gx + mm(Gw, P1))
            zero = row_norms(A) <= ZERO_ROW_TOL
            # screen rows over scaled x:  -B1 x <= b0 (x-only rows),  +-(Qx x + q0) <= 0
            xa, xb = np.vstack([-B1[zero], Qx, -Qx]), np.concatenate([b0[zero], -q0, q0])
            # A candidate lies in its region, so in the state box [-1, 1]^n: rows the box implies
            # screen nothing, and repeated rows (the same guard at several steps) once is enough.
            keep = np.abs(xa).sum(axis=1) > xb
            xa, xb = xa[keep], xb[keep]
            if xa.shape[0]:
                _, first = np.unique(np.round(np.hstack([xa, xb[:, None]]), 12), axis=0, return_index=True)
                first = np.sort(first)
                xa, xb = xa[first], xb[first]
            ex_rows.append(xa)
            ex_rhs.append(xb)
            ex_starts.append(ex_starts[-1] + ex_rows[-1].shape[0])
            self.lp.append((np.ascontiguousarray(A[~zero]), np.ascontiguousarray(b0[~zero]), np.ascontiguousarray(B1[~zero])))
            self.ij.append((pair.i, pair.j))
        self.ex_A = np.ascontiguousarray(np.vstack(ex_rows)) if ex_rows else np.zeros((0, n))
        self.ex_b = np.ascontiguousarray(np.concatenate(ex_rhs)) if ex_rhs else np.zeros(0)
        self.ex_starts = np.array(ex_starts, dtype=np.int64)
        self._start_counters()

    def _start_counters(self) -> None:
        """The cuts and counters of a fresh set of pieces (nothing learnt from data yet)."""
        n, P = self.n, len(self.lp)
        self.cut_A = np.zeros((P, PAIR_CUTS_PER_PIECE, n))
        self.cut_b = np.zeros((P, PAIR_CUTS_PER_PIECE))
        self.cut_count = np.zeros(P, dtype=np.int64)
        self._cut_next = np.zeros(P, dtype=np.int64)
        self.survivors = np.zeros(max(P, 1), dtype=np.int64)
        self.ex_last = self.ex_starts[:-1].copy()  # the row that last excluded each piece (screen order only)
        self._last_hit = -1
        self.n_tests = self.n_lps = self.n_hits = self.n_cuts = 0
        self.n_pairs = P

    @classmethod
    def cached(cls, analysis, progress: Callable[[int, int], None] | None = None) -> "_PairPieces":
        """The pieces of ``analysis``, through the active cache (:mod:`hybobs_opt.cache`) when there is one."""
        from ..cache import active_cache, analysis_key_parts

        cache = active_cache()
        if cache is None:
            return cls(analysis, progress)
        parts = analysis_key_parts(analysis)
        what = f"lookup tables of B~_T for {analysis.system.name!r} (T = {analysis.T})"
        return cls.from_arrays(cache.arrays("lookup-pieces", parts, lambda: cls(analysis, progress).to_arrays(), what))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The pieces as flat arrays (:meth:`from_arrays` restores them; the cuts are not kept)."""
        shapes = np.array([A.shape for A, _, _ in self.lp], dtype=np.int64).reshape(-1, 2)
        return {"n": np.array(self.n), "sx": self.sx, "cx": self.cx, "radius": np.array(self.radius),
                "ex_A": self.ex_A, "ex_b": self.ex_b, "ex_starts": self.ex_starts,
                "ij": np.array(self.ij, dtype=np.int64).reshape(-1, 2), "lp_shapes": shapes,
                "lp_A": np.concatenate([A.ravel() for A, _, _ in self.lp]) if self.lp else np.zeros(0),
                "lp_b0": np.concatenate([b0 for _, b0, _ in self.lp]) if self.lp else np.zeros(0),
                "lp_B1": np.vstack([B1 for _, _, B1 in self.lp]) if self.lp else np.zeros((0, self.n))}

    @classmethod
    def from_arrays(cls, arrays) -> "_PairPieces":
        """The pieces written by :meth:`to_arrays` (fresh counters and no cuts)."""
        self = cls.__new__(cls)
        self.n = int(arrays["n"])
        self.sx, self.cx = np.asarray(arrays["sx"], dtype=float), np.asarray(arrays["cx"], dtype=float)
        self.radius = float(arrays["radius"])
        self.ex_A = np.ascontiguousarray(arrays["ex_A"], dtype=float)
        self.ex_b = np.ascontiguousarray(arrays["ex_b"], dtype=float)
        self.ex_starts = np.ascontiguousarray(arrays["ex_starts"], dtype=np.int64)
        self.ij = [(int(i), int(j)) for i, j in arrays["ij"]]
        self.lp = []
        a = r = 0
        lp_A, lp_b0, lp_B1 = arrays["lp_A"], arrays["lp_b0"], arrays["lp_B1"]
        for rows, cols in arrays["lp_shapes"]:
            rows, cols = int(rows), int(cols)
            self.lp.append((np.ascontiguousarray(lp_A[a : a + rows * cols].reshape(rows, cols)),
                            np.ascontiguousarray(lp_b0[r : r + rows]), np.ascontiguousarray(lp_B1[r : r + rows])))
            a += rows * cols
            r += rows
        if len(self.ij) != len(self.lp) or self.ex_starts.size != len(self.lp) + 1:
            raise ModelError("lookup tables", "one (i, j) pair and one row range per piece",
                             f"{len(self.ij)} pairs, {self.ex_starts.size - 1} ranges, {len(self.lp)} pieces")
        self._start_counters()
        return self

    @classmethod
    def empty(cls, n: int) -> "_PairPieces":
        """No pieces (the kernel's arguments when another ``B~_T`` test is used)."""
        self = cls.__new__(cls)
        self.n, self.sx, self.cx = n, np.ones(n), np.zeros(n)
        self.ex_A, self.ex_b, self.ex_starts = np.zeros((0, n)), np.zeros(0), np.zeros(1, dtype=np.int64)
        self.cut_A, self.cut_b = np.zeros((0, PAIR_CUTS_PER_PIECE, n)), np.zeros((0, PAIR_CUTS_PER_PIECE))
        self.cut_count, self.survivors = np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64)
        self.ex_last = np.zeros(0, dtype=np.int64)
        return self

    def contains(self, x: np.ndarray) -> bool:
        """Is ``x`` (original coordinates) in ``B~_T`` (closed, ``LOOKUP_MEMBERSHIP_TOL``)?"""
        xs = np.ascontiguousarray((x - self.cx) / self.sx)
        cnt = K.pair_screen(xs, self.ex_A, self.ex_b, self.ex_starts, self.cut_A, self.cut_b, self.cut_count,
                            LOOKUP_MEMBERSHIP_TOL, self.survivors, self.ex_last)
        return self.decide(x, cnt)

    def decide(self, x: np.ndarray, cnt: int) -> bool:
        """:meth:`contains` after the screen: ``survivors[:cnt]`` are the pieces left for LPs."""
        self.n_tests += 1
        xs = (x - self.cx) / self.sx
        order = self.survivors[:cnt]
        if self._last_hit >= 0 and cnt > 1:
            hit = np.nonzero(order == self._last_hit)[0]
            if hit.size:
                order = np.concatenate([[self._last_hit], np.delete(order, hit[0])])
        tol = LOOKUP_MEMBERSHIP_TOL
        for q in order:
            A, b0, B1 = self.lp[q]
            b = b0 + mm(B1, xs)
            self.n_lps += 1
            if A.shape[0] == 0:
                inside = True
            else:
                value, w = _max_margin(A, b, self.radius, -tol, f"x in Proj_x(R_{self.ij[q]})")
                inside = value > -tol
                if not inside:
                    self._add_cut(int(q), A, b0, B1, b, xs, w)
            if inside:
                self._last_hit = int(q)
                self.n_hits += 1
                return True
        return False

    def _add_cut(self, q: int, A, b0, B1, b, xs, w) -> None:
        """Cache the cut of an LP that excluded ``x`` (see the class docstring), if it certifies."""
        if w is None or A.shape[1] == 0:
            return
        resid = b - mm(A, w)
        t = float(np.min(resid))
        active = np.nonzero(resid <= t + NEAR_ACTIVE_TOL)[0]
        M = np.vstack([A[active].T, np.ones((1, active.size))])
        rhs = np.zeros(M.shape[0])
        rhs[-1] = 1.0
        try:
            lam, _ = nnls(M, rhs)
        except RuntimeError:
            return
        if lam.sum() <= 0:
            return
        lam = lam / lam.sum()
        slack = self.radius * norm(mm(A[active].T, lam))
        a_cut = -mm(lam, B1[active])
        b_cut = dot(lam, b0[active]) + slack + LOOKUP_MEMBERSHIP_TOL
        if not dot(a_cut, xs) > b_cut:
            return  # the multipliers do not certify the exclusion of xs itself: no use as a cut
        c = int(self._cut_next[q])
        self.cut_A[q, c] = a_cut
        self.cut_b[q, c] = b_cut
        self._cut_next[q] = (c + 1) % PAIR_CUTS_PER_PIECE
        self.cut_count[q] = min(PAIR_CUTS_PER_PIECE, int(self.cut_count[q]) + 1)
        self.n_cuts += 1

    def stats(self) -> dict:
        return {"n_btilde_pieces": self.n_pairs, "n_btilde_windows_with_lps": self.n_tests, "n_btilde_lps": self.n_lps,
                "n_btilde_hits": self.n_hits, "n_btilde_cuts": self.n_cuts}


class _ExactTest:
    """The ``"exact"`` variant: is another state of a rank-deficient region consistent with the data?

    Per region ``P_j``, ``j`` not in ``I``, precomputed in scaled state coordinates: the SVD of
    ``C_j``, the nullspace ``N_j``, and the rows of ``P_j`` split into those that involve ``x``
    and those that only involve ``U`` (which the data decide: closed, ``LOOKUP_MEMBERSHIP_TOL``).
    Online: the output residual of ``Y - D_j U - f_j`` outside ``range(C_j)`` screens most
    regions without an LP; for the others one certified LP over ``v`` (``x = x_0 + N_j v``) asks
    whether a state of ``P_j`` (closed, the same tolerance) has these outputs.
    """

    def __init__(self, analysis, output_rtol: float):
        n, T, p = analysis.system.n, analysis.T, analysis.system.p
        self.n, self.pT = n, p * T
        self.output_rtol = output_rtol
        scale, centre = analysis.enumeration.scale, analysis.enumeration.centre
        sx, cx = scale[:n], centre[:n]
        self.data = []
        for j in analysis.rank_deficient:
            reg = analysis.regions[j]
            E = reg.C * sx[None, :]
            Uu, s, Vt = svd(E)
            r = numerical_rank(s, RANK_RTOL)
            rn = np.maximum(row_norms(reg.H * scale[None, :]), np.finfo(float).tiny)
            Gx = reg.H[:, :n] * sx[None, :] / rn[:, None]
            HU = reg.H[:, n:] / rn[:, None]
            h = (reg.h - mm(reg.H[:, :n], cx)) / rn
            xrow = row_norms(Gx) > ZERO_ROW_TOL
            N = np.ascontiguousarray(Vt[r:].T)
            self.data.append((j, reg.D, reg.f + mm(reg.C, cx), np.ascontiguousarray(Uu[:, :r]), s[:r], np.ascontiguousarray(Vt[:r].T), N, Gx[xrow], HU[xrow], h[xrow],
                              HU[~xrow], h[~xrow], float(np.sqrt(n) * (1.0 + 10 * LOOKUP_MEMBERSHIP_TOL))))
        self.n_tests = self.n_lps = 0

    def other_state_consistent(self, z: np.ndarray) -> bool:
        self.n_tests += 1
        Y, U = z[: self.pT], z[self.pT :]
        ytol = self.output_rtol * max(1.0, float(np.max(np.abs(Y))))
        tol = LOOKUP_MEMBERSHIP_TOL
        for (j, D, f, Ur, sr, Vr, N, Gx, HUx, hx, HU0, h0, radius) in self.data:
            if HU0.shape[0] and np.any(mm(HU0, U) - h0 > tol):
                continue  # the inputs themselves leave P_j
            e = Y - mm(D, U) - f
            coef = mm(Ur.T, e)
            if norm(e - mm(Ur, coef)) > ytol:
                continue  # no state of P_j has these outputs
            v0 = mm(Vr, coef / sr)
            b = hx - mm(HUx, U) - mm(Gx, v0)
            self.n_lps += 1
            if N.shape[1] == 0:
                if np.all(b >= -tol):
                    return True
                continue
            value, _ = _max_margin(mm(Gx, N), b, radius + norm(v0), -tol, f"lookup exact test, region {j}")
            if value > -tol:
                return True
        return False

    def stats(self) -> dict:
        return {"n_exact_tests": self.n_tests, "n_exact_lps": self.n_lps}


def reduced_unobservable_polytopes(analysis) -> list[Polytope]:
    """H-representations over ``x`` of the pieces ``Proj_x(R_ij)`` of ``B~_T`` (eq. 15), by exact projection.

    All non-empty ``R_ij`` (``i`` in ``I``, ``j`` not in ``I``) are used, including those whose
    projection is lower-dimensional (returned with their affine hull as paired rows): the data of
    a true state in ``P_j`` can force the candidate of ``P_i`` onto such a flat piece.  Costly for
    many pieces (model 17, T = 5: 778 pieces, minutes); the observer's default tests the pieces
    with LPs instead (:class:`_PairPieces`).
    """
    pieces = []
    n = analysis.system.n
    for pair in analysis.reduced_pairs_all_dimensions():
        P = Polytope(pair.G, pair.g)
        pieces.append(P.project_with_equalities(pair.E, pair.e, list(range(n))))
    return pieces
