"""Certificates that an observer LMI of paper 004 has no solution, re-checked in plain numpy.

Write the LMI of :mod:`.observer_lmi` as ``B(P, Y, eps) < 0`` (strict, as in Theorem 1: the error
must decay); ``B`` is linear in ``(P, Y, eps)``.  A symmetric ``Z >= 0`` with

1. ``<Z, B(0, Y, 0)> = 0`` for every ``Y`` (the gain cannot help: ``Z_11 C_l^T = 0``, ``Z_13 = 0``),
2. ``W := B_P^*(Z) >= 0``, i.e. ``<Z, B(P, 0, 0)> = <W, P>`` (``W = A Z_11 + Z_11 A^T + sigma Z_11
   + F Z_12^T + Z_12 F^T``),
3. ``g_k := <Z, B(0, 0, e_k)> >= 0`` for each S-procedure multiplier (the terms of eq. (20) weighed by
   ``Z``; one ``g`` for the paper's single multiplier),
4. ``tr Z = 1`` (``Z`` is not zero),

proves infeasibility: for every ``P > 0``, every ``L`` (``Y = P L``) and multipliers ``eps_k > 0``,
``<Z, B> = <W, P> + sum_k eps_k g_k >= 0``, while ``B < 0`` and ``Z >= 0, Z != 0`` force
``<Z, B> < 0``.  That scalar inequality is the certificate; :meth:`DualCertificate.verify`
re-checks 1-4 with eigenvalues and traces, evaluating ``B`` by its own numpy code.  The re-check
accepts violations up to :data:`~hybobs_opt.tolerances.CERTIFICATE_RTOL` (relative), so what is
proven is that no solution has a margin ``-lambda_max(B) / tr P`` above that tolerance.  (The
normalisation ``tr Z = 1`` rather than ``tr W + g = 1`` also certifies the boundary cases where no
strict solution exists but ``B <= 0`` is reachable, e.g. a mode that neither decays nor grows.)

Two sources of ``Z``:

* **the solver** -- Clarabel's Farkas ray for the infeasible LMI constraint, or, if that is
  missing or fails the re-check, the solution of the alternative SDP 1-4 (:class:`AlternativeSDP`);
* **the structure** (Theorems 2-4 of paper 004, stated for the system at hand) -- an eigenvector
  ``v`` of ``A`` with ``Re(lambda) >= -sigma/2`` that the linear outputs do not see (``C_l v = 0``)
  and along which the S-procedure terms ``-U_i V_i |E_i v|^2 - M_j N_j |C_j v|^2`` are not negative:
  then ``Z = Re(v v^*) (+) 0`` satisfies 1-4, because ``v^* (1,1) v = (2 Re lambda + sigma)
  v^* P v + eps v^* Q v > 0`` whatever ``L`` is.  Theorem 4 is the case ``A = 0`` (every vector is
  an eigenvector) with non-monotonic ``f_i`` acting along an unmeasured ``v``; Theorem 3 the case of
  linear dynamics that are not Hurwitz and non-monotonic outputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cvxpy as cp
import numpy as np

from ..errors import InfeasibleError, SolverError
from ..tolerances import CERTIFICATE_RTOL
from .bounds import DerivativeBound, JacobianBounds
from .lmi_model import LMI_NAMES, LMIData, LMIParameters, SectorData
from .solve import INFEASIBLE, POINT_STATUSES, SOLVER, solve_problem
from ..results import Certificate


# ---------------------------------------------------------------------------- the numpy re-check
def _inner(X: np.ndarray, Y: np.ndarray) -> float:
    return float(np.sum(X * Y))


@dataclass(frozen=True)
class CertificateCheck:
    """Numbers of the numpy re-check of a dual certificate (after normalising ``tr Z = 1``)."""

    ok: bool
    min_eig_Z: float
    min_eig_W: float
    trace_W: float
    g: float
    y_residual: float
    messages: tuple[str, ...] = ()
    g_components: tuple[float, ...] = ()

    def to_dict(self) -> dict:
        return {"ok": self.ok, "min_eig_Z": self.min_eig_Z, "min_eig_W": self.min_eig_W, "trace_W": self.trace_W,
                "g": self.g, "g_components": list(self.g_components), "y_residual": self.y_residual,
                "messages": list(self.messages)}


@dataclass(frozen=True)
class DualCertificate(Certificate):
    """A dual PSD multiplier ``Z`` of an observer LMI (scaled coordinates) and its re-check.

    Parameters
    ----------
    data : LMIData
        The LMI's matrices in the coordinates of ``Z``.
    sector : SectorData
        The region's bounds.
    sigma : float
        The decay rate of the LMI.
    Z : array
        The multiplier as found (before the projection of the re-check).
    source : str
        ``"Clarabel Farkas ray"``, ``"alternative SDP"`` or ``"structure"``.
    per_function : bool
        The LMI has one multiplier per function: condition 3 must hold for each multiplier
        (``g_k = <Z, B(0, 0, e_k)> >= 0``), not only for their sum.

    See Also
    --------
    InfeasibilityCertificate : Carries one as ``dual``.
    certify_infeasible : Builds it from a solve's Farkas duals.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import ObserverLMI, certify_infeasible, jacobian_bounds
    >>> lmi = ObserverLMI(vehicle)
    >>> sol = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140))), 0.0)
    >>> dual = certify_infeasible(lmi, sol).dual
    >>> dual.Z.shape, dual.sigma
    ((7, 7), 0.0)
    >>> dual.verify()
    True
    """

    data: LMIData
    sector: SectorData
    sigma: float
    Z: np.ndarray
    source: str
    per_function: bool = False

    def _B(self, P, Yl, Yn, eps) -> np.ndarray:
        return self.data.matrix(P, Yl, Yn, eps, self.sector, self.sigma)

    def _y_basis(self) -> list[np.ndarray]:
        n, pl, pn = self.data.n, self.data.p_lin, self.data.p_nl
        out = []
        for shape, which in (((n, pl), 0), ((n, pn), 1)):
            for a in range(shape[0]):
                for b in range(shape[1]):
                    Y = np.zeros(shape)
                    Y[a, b] = 1.0
                    zl = Y if which == 0 else np.zeros((n, pl))
                    zn = Y if which == 1 else np.zeros((n, pn))
                    out.append(self._B(np.zeros((n, n)), zl, zn, 0.0))
        return out

    def W_of(self, Z: np.ndarray) -> np.ndarray:
        """``W`` with ``<Z, B(P, 0, 0)> = <W, P>`` for every symmetric ``P`` (basis evaluation).

        Parameters
        ----------
        Z : (k, k) ndarray
            A symmetric multiplier of the LMI's size.

        Returns
        -------
        (n, n) ndarray
            The symmetric ``W``.
        """
        n = self.data.n
        zl, zn = np.zeros((n, self.data.p_lin)), np.zeros((n, self.data.p_nl))
        W = np.zeros((n, n))
        for a in range(n):
            for b in range(a, n):
                S = np.zeros((n, n))
                S[a, b] = S[b, a] = 1.0
                v = _inner(Z, self._B(S, zl, zn, 0.0))
                if a == b:
                    W[a, a] = v
                else:
                    W[a, b] = W[b, a] = 0.5 * v
        return W

    def g_of(self, Z: np.ndarray) -> np.ndarray:
        """``g_k = <Z, B(0, 0, e_k)>`` for each multiplier (one entry for the paper's single one).

        Parameters
        ----------
        Z : (k, k) ndarray
            A symmetric multiplier of the LMI's size.

        Returns
        -------
        ndarray
            ``g_k = <Z, B(0, 0, e_k)>`` for each multiplier (one entry for the paper's single one).
        """
        n, k = self.data.n, self.data.r + self.data.p_nl
        zeros = (np.zeros((n, n)), np.zeros((n, self.data.p_lin)), np.zeros((n, self.data.p_nl)))
        if not self.per_function or k <= 1:
            return np.array([_inner(Z, self._B(*zeros, 1.0))])
        return np.array([_inner(Z, self._B(*zeros, np.eye(k)[i])) for i in range(k)])

    def projected(self) -> np.ndarray:
        """``Z`` projected (least squares) onto ``{<Z, B(0, Y, 0)> = 0 for all Y}``.

        Returns
        -------
        ndarray
            ``Z`` projected (least squares) onto ``{<Z, B(0, Y, 0)> = 0 for all Y}``.
        """
        Z = 0.5 * (self.Z + self.Z.T)
        basis = self._y_basis()
        if not basis:
            return Z
        G = np.array([[_inner(Bi, Bj) for Bj in basis] for Bi in basis])
        rhs = np.array([_inner(Z, Bi) for Bi in basis])
        c = np.linalg.lstsq(G, rhs, rcond=None)[0]
        return Z - sum(ci * Bi for ci, Bi in zip(c, basis))

    def check(self) -> CertificateCheck:
        """The numpy re-check (computed once per certificate; a modified copy made with
        ``dataclasses.replace`` is re-checked from scratch).

        Returns
        -------
        CertificateCheck
            The numpy re-check (computed once per certificate; a modified copy made with
            ``dataclasses.replace`` is re-checked from scratch).
        """
        return self._checked

    @cached_property
    def _checked(self) -> CertificateCheck:
        """Re-check conditions 1-4 of the module docstring in numpy (cached)."""
        Zraw = 0.5 * (self.Z + self.Z.T)
        scale_Z = float(np.linalg.norm(Zraw)) or 1.0
        basis = self._y_basis()
        y_res_raw = max((abs(_inner(Zraw, Bi)) for Bi in basis), default=0.0) / scale_Z
        Z = self.projected()
        W, gk = self.W_of(Z), self.g_of(Z)
        t = float(np.trace(Z))
        msgs = []
        if not np.isfinite(t) or t <= 0:
            res = CertificateCheck(False, float("nan"), float("nan"), float(np.trace(W)), float(gk.sum()), y_res_raw,
                                   (f"tr Z = {t:.3g} is not positive",))
            return res
        Z, W, gk = Z / t, W / t, gk / t
        g = float(gk.sum())
        nZ = float(np.linalg.norm(Z))
        # The adjoint maps ||Z|| to at most this much W (so W's tolerance scales with it).
        opnorm = 2 * np.linalg.norm(self.data.A + self.sector.a_shift, 2) + self.sigma + 2 * np.linalg.norm(self.data.F, 2) + 1.0
        tol_Z, tol_W = CERTIFICATE_RTOL * nZ, CERTIFICATE_RTOL * max(1.0, nZ * opnorm)
        ez = float(np.linalg.eigvalsh(Z).min())
        ew = float(np.linalg.eigvalsh(W).min())
        ok = True
        if ez < -tol_Z:
            ok = False
            msgs.append(f"Z is not PSD: min eigenvalue {ez:.3g} (tolerance {tol_Z:.3g})")
        if ew < -tol_W:
            ok = False
            msgs.append(f"W is not PSD: min eigenvalue {ew:.3g} (tolerance {tol_W:.3g})")
        if float(gk.min()) < -tol_W:
            ok = False
            k = int(np.argmin(gk))
            msgs.append(f"g = {gk[k]:.3g} is negative" if gk.size == 1 else f"g_{k} = {gk[k]:.3g} (multiplier {k}) is negative")
        if y_res_raw > 1e3 * CERTIFICATE_RTOL:
            ok = False
            msgs.append(f"Z does not annihilate the gain variables: residual {y_res_raw:.3g} of ||Z||")
        res = CertificateCheck(ok, ez, ew, float(np.trace(W)), g, y_res_raw, tuple(msgs), tuple(float(v) for v in gk))
        return res

    @property
    def reason(self) -> str:
        """What the multiplier proves (the :class:`~hybobs_opt.results.Certificate` protocol)."""
        return (f"a dual PSD multiplier Z ({self.source}) of the observer LMI at decay rate {self.sigma:.6g}: "
                "<Z, B(P, PL, eps)> >= 0 for every P > 0, eps > 0 and every gain L, so B < 0 has no solution")

    def verify(self) -> bool:
        """True when the numpy re-check confirms the certificate (no solver involved).

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        return self.check().ok

    @property
    def inequality(self) -> str:
        c = self.check()
        return (f"<Z, B(P, PL, eps)> = <W, P> + sum_k eps_k g_k with W >= 0 (min eigenvalue {c.min_eig_W:.3g}), "
                f"g_k >= 0 (sum {c.g:.4g}) and tr Z = 1: non-negative for every P > 0, eps > 0 and every gain L, "
                f"whereas B < 0 and Z >= 0 (min eigenvalue {c.min_eig_Z:.3g}), Z != 0 force <Z, B> < 0 "
                f"(to the re-check tolerance {CERTIFICATE_RTOL:g}).")

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        c = self.check()
        return {"source": self.source, "verified": c.ok, "check": c.to_dict(), "inequality": self.inequality}


# ---------------------------------------------------------------------------- the alternative SDP
class AlternativeSDP:
    """Conditions 1-4 as an SDP in ``Z`` (built once, region bounds as ``Parameter``s)."""

    def __init__(self, data: LMIData, shifted: bool = False, per_function: bool = False):
        self.data = data
        self.per_function = per_function
        n, r, pn, pl = data.n, data.r, data.p_nl, data.p_lin
        N = data.size
        self.Z = cp.Variable((N, N), PSD=True, name="Z")
        Z = self.Z
        Z11, Z12, Z13 = Z[:n, :n], Z[:n, n:n + r], Z[:n, n + r:]
        self.par = LMIParameters.create(data, shifted)
        par = self.par
        cons = []
        if pl:
            cons.append(Z11 @ data.C_lin.T == 0)
        if pn:
            if par.m_shift is not None:
                cons.append(Z13 + Z11 @ data.C_nl.T @ cp.diag(par.m_shift) == 0)
            else:
                cons.append(Z13 == 0)
        W = data.A @ Z11 + Z11 @ data.A.T + par.sigma * Z11
        if r:
            W = W + data.F @ Z12.T + Z12 @ data.F.T
        if par.a_shift is not None:
            W = W + par.a_shift @ Z11 + Z11 @ par.a_shift.T
        W = 0.5 * (W + W.T)
        # g_k = <Z, B(0, 0, e_k)>: the S-procedure terms of each function weighed by Z
        parts = []
        if r:
            parts.append(-cp.multiply(par.uv, cp.diag(data.E @ Z11 @ data.E.T)) + 2 * cp.multiply(par.upv, cp.diag(data.E @ Z12))
                         - cp.diag(Z[n:n + r, n:n + r]))
        if pn:
            parts.append(-cp.multiply(par.mn, cp.diag(data.C_nl @ Z11 @ data.C_nl.T))
                         + 2 * cp.multiply(par.mpn, cp.diag(data.C_nl @ Z13)) - cp.diag(Z[n + r:, n + r:]))
        gk = cp.hstack(parts) if len(parts) > 1 else parts[0]
        g = cp.sum(gk)
        cons += [W >> 0, (gk >= 0) if per_function else (g >= 0), cp.trace(Z) == 1]
        self.problem = cp.Problem(cp.Minimize(0), cons)

    def solve(self, sector: SectorData, sigma: float) -> np.ndarray | None:
        """A multiplier ``Z`` or ``None`` when the solver finds none (or is not sure)."""
        self.par.assign(sector, sigma)
        out = solve_problem(self.problem)
        if out.status not in POINT_STATUSES or self.Z.value is None:
            return None
        return np.asarray(self.Z.value, dtype=float)


# ---------------------------------------------------------------------------- structural reason
@dataclass(frozen=True)
class StructuralObstruction:
    """A direction ``v`` that no gain can stabilise (Theorems 2-4 of paper 004, generalised).

    ``v`` is an eigenvector of ``A`` (eigenvalue ``lam``, ``Re lam >= -sigma/2``) with ``C_l v = 0``
    along which the S-procedure terms add ``s_term = v^* Q v >= 0`` to the (1,1) block.
    """

    v: np.ndarray
    v_scaled: np.ndarray
    lam: complex
    s_term: float
    terms: tuple[tuple[str, float], ...]


def structural_obstruction(data: LMIData, sector: SectorData, sigma: float, d: np.ndarray) -> StructuralObstruction | None:
    """Search the eigen-directions of ``A`` for the obstruction of Theorems 2-4 (scaled data).

    Parameters
    ----------
    data : LMIData
        Scaled LMI data (``x = diag(d) x_bar``).
    sector : SectorData
    sigma : float
    d : array
        The scaling, to report ``v`` in model coordinates.
    """
    n = data.n
    Q = -(data.E.T * sector.uv) @ data.E - (data.C_nl.T * sector.mn) @ data.C_nl
    qscale = max(1.0, float(np.abs(Q).max()))
    A = data.A + sector.a_shift
    lam_all = np.linalg.eigvals(A)
    ascale = 1.0 + float(np.abs(A).max())
    seen: list[complex] = []
    best = None
    for lam in lam_all:
        if lam.real < -0.5 * sigma - 1e-9 * ascale or any(abs(lam - s) <= 1e-7 * ascale for s in seen):
            continue
        seen.append(lam)
        M = A - lam * np.eye(n)
        _, sv, vh = np.linalg.svd(M)
        K = vh[np.sum(sv > 1e-7 * ascale):].conj().T
        if data.p_lin and K.shape[1]:
            _, sv2, vh2 = np.linalg.svd(data.C_lin @ K)
            rank = int(np.sum(sv2 > 1e-9 * max(1.0, sv2.max(initial=0.0))))
            K = K @ vh2[rank:].conj().T
        if K.shape[1] == 0:
            continue
        H = K.conj().T @ Q @ K
        w, U = np.linalg.eigh(0.5 * (H + H.conj().T))
        v = K @ U[:, -1]
        val = float(w[-1])
        decay = 2 * lam.real + sigma
        if val > 1e-9 * qscale or (val >= -1e-12 * qscale and decay > 1e-9 * ascale):
            key = val + decay
            if best is None or key > best[0]:
                best = (key, v, lam, val)
    if best is None:
        return None
    _, v, lam, val = best
    # make v as real as possible and normalised in model coordinates
    k = int(np.argmax(np.abs(v)))
    v = v * np.exp(-1j * np.angle(v[k]))
    v_model = d * v
    v_model = v_model / np.linalg.norm(v_model)
    if np.allclose(v_model.imag, 0, atol=1e-12):
        v_model = np.real(v_model)
    u = v_model / d  # the same direction in scaled coordinates, unit length in model coordinates
    terms = []
    for i in range(data.r):
        terms.append((f"f[{i}]", float(-sector.uv[i] * abs(data.E[i] @ u) ** 2)))
    for j in range(data.p_nl):
        terms.append((f"h_nl[{j}]", float(-sector.mn[j] * abs(data.C_nl[j] @ u) ** 2)))
    return StructuralObstruction(v_model, v, complex(lam), float(sum(t for _, t in terms)), tuple(terms))


def obstruction_certificate(data: LMIData, sector: SectorData, sigma: float, ob: StructuralObstruction,
                            per_function: bool = False) -> DualCertificate:
    """``Z = Re(v v^*) (+) 0`` from a structural obstruction (scaled coordinates)."""
    v = ob.v_scaled
    Z11 = np.real(np.outer(v, v.conj()))
    Z = np.zeros((data.size, data.size))
    Z[:data.n, :data.n] = Z11
    return DualCertificate(data, sector, sigma, Z, "structure", per_function)


# ---------------------------------------------------------------------------- the certificate
@dataclass(frozen=True)
class InfeasibilityCertificate(Certificate):
    """Why an observer LMI of paper 004 has no solution, with checkable evidence.

    Parameters
    ----------
    reason : str
        The structural explanation, stated for the system at hand.
    theorem : str
        The paper's result whose mechanism applies (``"Theorem 4"``, ``"Theorem 3"``...).
    form : str
        The LMI: ``"(8)"``, ``"(22)"``, ``"(23)"`` (``"(45)"``-type for Theorem 5's transform).
    sigma : float
        Decay rate of the infeasible LMI (infeasibility at ``sigma = 0`` covers every ``sigma``).
    dual : DualCertificate or None
        The solver's multiplier (Farkas ray or alternative SDP), re-checked by :meth:`verify`.
    structural : DualCertificate or None
        The multiplier built from the structural obstruction, also re-checkable.
    obstruction : StructuralObstruction or None
    nonmonotonic : tuple of str
        Names of the non-monotonic functions on the region.
    solver_status : str
        The primal status that triggered the certification.
    region : dict or None
        The region (``SchedulingRegion.to_dict()``), ``None`` for the whole box.

    See Also
    --------
    certify_infeasible : Builds and checks one.
    DualCertificate : The dual multiplier it carries.
    diagnose : Attaches one to its diagnosis.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import ObserverLMI, certify_infeasible, jacobian_bounds
    >>> lmi = ObserverLMI(vehicle)
    >>> sol = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140))), 0.0)
    >>> cert = certify_infeasible(lmi, sol)
    >>> cert.theorem, cert.form, cert.nonmonotonic
    ('Theorem 4', '(23)', ('V sin(psi)',))
    >>> cert.verify(), cert.dual.verify()
    (True, True)
    >>> print(cert.reason)  # doctest: +ELLIPSIS
    Over psi in [0, 2.44346], V sin(psi) is non-monotonic (V sin(psi)' in [-7.66, ...
    """

    reason: str
    theorem: str
    form: str
    sigma: float
    dual: DualCertificate | None
    structural: DualCertificate | None
    obstruction: StructuralObstruction | None
    nonmonotonic: tuple[str, ...]
    solver_status: str
    region: dict | None = None

    def verify(self) -> bool:
        """Re-check the solver's dual certificate in numpy (``False`` when there is none).

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        return self.dual is not None and self.dual.verify()

    @property
    def verified(self) -> bool:
        return self.verify()

    @property
    def structural_verified(self) -> bool:
        return self.structural is not None and self.structural.verify()

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        ob = self.obstruction
        return {
            "verified": self.verify(),
            "reason": self.reason,
            "theorem": self.theorem,
            "lmi": self.form,
            "sigma": self.sigma,
            "nonmonotonic": list(self.nonmonotonic),
            "solver_status": self.solver_status,
            "region": self.region,
            "dual": None if self.dual is None else self.dual.to_dict(),
            "structural": None if self.structural is None else self.structural.to_dict(),
            "direction": None if ob is None else {
                "v": np.real(ob.v).tolist(), "eigenvalue_of_A": [ob.lam.real, ob.lam.imag], "s_procedure_term": ob.s_term},
        }


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def _direction_text(v: np.ndarray, names: tuple[str, ...]) -> str:
    v = np.real(v)
    k = int(np.argmax(np.abs(v)))
    if abs(abs(v[k]) - 1.0) < 1e-9:
        return f"e_{names[k]}"
    parts = [f"{v[i]:+.3g} e_{names[i]}" for i in range(v.size) if abs(v[i]) > 1e-9]
    return "(" + " ".join(parts) + ")"


def _bound_text(b: DerivativeBound) -> str:
    sym = ("U", "V") if b.kind == "f" else ("M", "N")
    return f"{b.name}' in [{_fmt(b.lower)}, {_fmt(b.upper)}] ({sym[0]} < 0 < {sym[1]})"


def explain(system, bounds: JacobianBounds, form: str, sigma: float, ob: StructuralObstruction | None,
            region_text: str) -> tuple[str, str]:
    """``(reason, theorem)`` for an infeasible LMI, in terms of the system's own functions."""
    nl_out = [b for b, lin in zip(bounds.h, bounds.linear_outputs) if not lin]
    nonmono = [b for b in (*bounds.f, *nl_out) if not b.monotonic]
    names = system.state_names
    lmi_name = LMI_NAMES.get(form, f"LMI {form}")
    theorem = {"(22)": "Theorem 3", "(23)": "Theorem 4"}.get(form, "Theorem 2")
    if ob is None:
        nm = ", ".join(b.name for b in nonmono) or "none"
        reason = (f"{lmi_name} is infeasible on {region_text}. Non-monotonic functions: {nm}. No single direction "
                  f"of the kind of Theorems 2-4 was found; the infeasibility rests on the solver's dual multiplier Z, "
                  f"re-checked in numpy.")
        return reason, "Theorem 1 (dual certificate)"
    v = ob.v
    acting = []
    for (label, term) in ob.terms:
        kind, idx = label.split("[")
        idx = int(idx[:-1])
        b = bounds.f[idx] if kind == "f" else nl_out[idx]
        if abs(term) > 1e-12 * max(1.0, abs(ob.s_term)):
            acting.append((b, term))
    pos = [b for b, t in acting if t > 0]
    mono_silent = [b for b in (*bounds.f, *nl_out) if b.monotonic and b not in [a for a, _ in acting]]
    d_text = _direction_text(v, names)
    parts = []
    if pos:
        which = " and ".join(b.name for b in pos)
        verb = "is" if len(pos) == 1 else "are"
        kinds = {b.kind for b in pos}
        term = " - ".join(t for k, t in (("f", "U_i V_i (E_i v)^2"), ("h", "M_j N_j (C_j v)^2")) if k in kinds)
        parts.append(f"Over {region_text}, {which} {verb} non-monotonic ({'; '.join(_bound_text(b) for b in pos)}), "
                     f"so {'its' if len(pos) == 1 else 'their'} S-procedure term -{term} in the (1,1) block is positive "
                     f"along v = {d_text}: it adds {_fmt(ob.s_term)} > 0.")
    else:
        parts.append(f"Over {region_text}, the S-procedure terms along v = {d_text} add {_fmt(ob.s_term)} >= 0 "
                     f"(no function pulls the (1,1) block negative along v).")
    if system.linear_outputs and any(system.linear_outputs):
        parts.append("The linear outputs do not measure this direction (C v = 0), so no gain L enters v^T (1,1) v.")
    else:
        parts.append("There are no linear outputs, and the gain of the nonlinear outputs sits only in the off-diagonal "
                     "block, so no gain L enters v^T (1,1) v.")
    lam = ob.lam
    lam_text = f"{lam.real:.4g}" if abs(lam.imag) < 1e-12 else f"{lam.real:.4g}{lam.imag:+.4g}i"
    if np.allclose(system.A, 0):
        parts.append("The linear part is zero (A v = 0), so nothing else can make the block negative along v.")
    else:
        parts.append(f"v is an eigenvector of A with eigenvalue {lam_text} (Re >= -sigma/2: A is not Hurwitz along v).")
    parts.append(f"Hence v^T (1,1) v = (2 Re(lambda) + sigma) v^T P v + {_fmt(ob.s_term)} > 0 for every P > 0 and every L: "
                 f"the (1,1) block of {lmi_name} cannot be negative definite: no constant gain satisfies {lmi_name}.")
    all_nonmono = all(not b.monotonic for b in ((*bounds.f,) if form == "(23)" else (*nl_out,) if form == "(22)" else (*bounds.f, *nl_out)))
    if form == "(23)":
        extra = ("" if all_nonmono else
                 f" It applies although {', '.join(b.name for b in mono_silent) or 'some f_i'} "
                 f"{'is' if len(mono_silent) == 1 else 'are'} monotonic: {'it does' if len(mono_silent) == 1 else 'they do'} not act along v.")
        parts.append(f"This is the mechanism of Theorem 4 (C v = 0 with non-monotonic f_i).{extra}")
    elif form == "(22)":
        extra = "" if all_nonmono else " (not all outputs are non-monotonic: the weighted sum of eq. (34)-(35) is what matters)"
        parts.append(f"This is Theorem 3: non-monotonic outputs and an open loop that is not asymptotically stable{extra}.")
    else:
        parts.append("This is the mechanism of Theorem 2 (the (1,1) block's necessary condition (27)).")
    return " ".join(parts), theorem


def certify_infeasible(lmi, sol, *, raise_error: bool = False, region_text: str | None = None) -> InfeasibilityCertificate:
    """Build and check the certificate for a solve of ``lmi`` that was not feasible.

    Parameters
    ----------
    lmi : ObserverLMI
        The compiled LMI that was solved.
    sol : LMISolution
        Its solve that was not feasible (bounds, ``sigma``, status and Farkas duals).
    raise_error : bool, default False
        Raise :class:`InfeasibleError` with the certificate instead of returning it.
    region_text : str, optional
        How the region is named in the messages (default: from ``sol.region``, or "the whole
        operating box").

    Returns
    -------
    InfeasibilityCertificate
        ``verify()`` is True when the solver's multiplier passed the numpy re-check.

    Raises
    ------
    InfeasibleError
        With ``raise_error=True``, carrying the certificate.
    SolverError
        When the solver's status was not a clear ``infeasible`` and neither the solver's
        multiplier nor the structural one could be verified: the answer is unknown.

    See Also
    --------
    InfeasibilityCertificate : What it returns.
    DualCertificate : The dual multiplier inside it.
    diagnose : Runs the LMI and this certificate on a range.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import ObserverLMI, certify_infeasible, jacobian_bounds
    >>> lmi = ObserverLMI(vehicle)
    >>> sol = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140))), 0.0)
    >>> cert = certify_infeasible(lmi, sol)
    >>> cert.theorem, cert.verify()
    ('Theorem 4', True)
    """
    sdata = lmi.sdata
    sector = sdata.sector(sol.bounds, lmi.shifted)
    sigma = sol.sigma
    per_function = lmi.eps.size > 1
    dual = None
    if sol.farkas is not None and sol.farkas.shape == (sdata.size, sdata.size):
        cand = DualCertificate(sdata, sector, sigma, sol.farkas, "Clarabel Farkas ray", per_function)
        if cand.verify():
            dual = cand
    if dual is None:
        Z = lmi.alternative().solve(sector, sigma)
        if Z is not None:
            cand = DualCertificate(sdata, sector, sigma, Z, "alternative SDP", per_function)
            if cand.verify():
                dual = cand
    ob = None if lmi.shifted else structural_obstruction(sdata, sector, sigma, lmi.d)
    structural = obstruction_certificate(sdata, sector, sigma, ob, per_function) if ob is not None else None
    if structural is not None and not structural.verify():
        structural = None
    if region_text is None:
        reg = sol.region
        region_text = "the whole operating box" if reg is None else f"{reg.name} in [{reg.lo:.6g}, {reg.hi:.6g}]"
    if dual is None and structural is None and sol.status != INFEASIBLE:
        raise SolverError(f"observer LMI {lmi.form} {region_text}", SOLVER, sol.status,
                          "the answer is unknown: no point passed the numpy re-check and no certificate was verified; "
                          "rescale the model or tighten the operating box")
    reason, theorem = explain(lmi.system, sol.bounds, lmi.form, sigma, ob, region_text)
    if lmi.gain_bound is not None and dual is None and structural is None:
        reason = (f"The solver reports the LMI infeasible with the gain bound ||L||_2 <= {lmi.gain_bound:.4g} "
                  f"(a sufficient condition: P >= alpha I); no certificate covers the bound. " + reason)
        theorem = "gain bound"
    nonmono = tuple(b.name for b in sol.bounds.nonmonotonic)
    cert = InfeasibilityCertificate(reason, theorem, lmi.form, sigma, dual, structural, ob, nonmono, sol.status,
                                    None if sol.region is None else sol.region.to_dict())
    if raise_error:
        what = f"observer LMI {lmi.form} {region_text}"
        if not (cert.verify() or cert.structural_verified):
            from .farkas import verified_farkas

            farkas = verified_farkas(lmi, f"the {what} at decay rate {sigma:g}")
            if farkas is None:
                raise SolverError(what, SOLVER, str(sol.status), "no point and no certificate of infeasibility verified: "
                                  "rescale the model or lower the decay rate")
            raise InfeasibleError(what, farkas, f"{theorem}; {farkas.reason}")
        raise InfeasibleError(what, cert, theorem)
    return cert
