"""The model of the observer LMIs of paper 004 (Theorem 1's (8), Corollaries 1.1-1.2's (22), (23)):
the system data in numpy (:class:`LMIData`, the sector bounds of each nonlinearity), and the
LMI as a cvxpy expression of ``P``, ``Y`` and the multiplier ``eps`` with the bounds as
``Parameter`` objects.  The compiled problem and its solutions are :mod:`.observer_lmi`; the
infeasibility certificates (:mod:`.certificates`) read the same model.
"""

from __future__ import annotations

from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds

# ---------------------------------------------------------------------------- numpy model of the LMI
@dataclass(frozen=True)
class SectorData:
    """The region-dependent numbers of the LMI: ``U V``, ``(U+V)/2``, ``M N``, ``(M+N)/2``.

    ``a_shift`` and ``m_shift`` are non-zero only for the transformed LMI of Theorem 5
    (``A + F U E`` and the output injection through ``M C``); see :mod:`.subtraction`.
    """

    uv: np.ndarray
    upv: np.ndarray
    mn: np.ndarray
    mpn: np.ndarray
    a_shift: np.ndarray
    m_shift: np.ndarray


@dataclass(frozen=True)
class LMIData:
    """The constant matrices of the LMI (``A, F, E, C_l, C_n``), in whatever coordinates."""

    A: np.ndarray
    F: np.ndarray
    E: np.ndarray
    C_lin: np.ndarray
    C_nl: np.ndarray

    @property
    def n(self) -> int:
        return self.A.shape[0]

    @property
    def r(self) -> int:
        return self.F.shape[1]

    @property
    def p_lin(self) -> int:
        return self.C_lin.shape[0]

    @property
    def p_nl(self) -> int:
        return self.C_nl.shape[0]

    @property
    def size(self) -> int:
        return self.n + self.r + self.p_nl

    def scaled(self, d: np.ndarray) -> "LMIData":
        """The same LMI in coordinates ``x = diag(d) x_bar``."""
        D, Di = np.diag(d), np.diag(1.0 / d)
        return LMIData(Di @ self.A @ D, Di @ self.F, self.E @ D, self.C_lin @ D, self.C_nl @ D)

    def sector(self, bounds: JacobianBounds, shifted: bool = False) -> SectorData:
        """Sector data of ``bounds``; ``shifted`` gives Theorem 5's transformed functions."""
        U, V = bounds.U, bounds.V
        M, N = bounds.M, bounds.N
        if shifted:
            return SectorData(np.zeros_like(U), (V - U) / 2, np.zeros_like(M), (N - M) / 2,
                              self.F @ np.diag(U) @ self.E if self.r else np.zeros((self.n, self.n)), M.copy())
        return SectorData(U * V, (U + V) / 2, M * N, (M + N) / 2, np.zeros((self.n, self.n)), np.zeros_like(M))

    def split_multipliers(self, eps) -> tuple[np.ndarray, np.ndarray]:
        """``(eps_f, eps_h)``: one S-procedure multiplier per ``f_i`` and per nonlinear ``h_j``.

        A scalar ``eps`` is the paper's single multiplier (eq. 21), repeated; a vector of length
        ``r + p_nl`` gives one multiplier per function (the per-function condition of
        :mod:`.hierarchy`).
        """
        e = np.asarray(eps, dtype=float).reshape(-1)
        if e.size == 1:
            return np.full(self.r, e[0]), np.full(self.p_nl, e[0])
        if e.size != self.r + self.p_nl:
            raise ValueError(f"eps: 1 or {self.r + self.p_nl} multipliers expected, got {e.size}")
        return e[:self.r], e[self.r:]

    def matrix(self, P, Y_lin, Y_nl, eps, s: SectorData, sigma: float) -> np.ndarray:
        """The LMI matrix at a point, in plain numpy (the solver-independent re-check).

        ``eps`` is the single multiplier of the paper or one per function (``r + p_nl`` values).
        """
        n, r, pn = self.n, self.r, self.p_nl
        P = np.asarray(P, dtype=float)
        Y_lin = np.asarray(Y_lin, dtype=float).reshape(n, self.p_lin)
        Y_nl = np.asarray(Y_nl, dtype=float).reshape(n, pn)
        ef, eh = self.split_multipliers(eps)
        Aeff = self.A + s.a_shift
        B11 = P @ Aeff + Aeff.T @ P - Y_lin @ self.C_lin - self.C_lin.T @ Y_lin.T + sigma * P
        if pn:
            K = Y_nl @ np.diag(s.m_shift) @ self.C_nl
            B11 = B11 - K - K.T
        B11 = B11 - (self.E.T * (ef * s.uv)) @ self.E - (self.C_nl.T * (eh * s.mn)) @ self.C_nl
        out = np.zeros((n + r + pn, n + r + pn))
        out[:n, :n] = B11
        if r:
            B12 = P @ self.F + self.E.T * (ef * s.upv)
            out[:n, n:n + r] = B12
            out[n:n + r, :n] = B12.T
            out[n:n + r, n:n + r] = -np.diag(ef)
        if pn:
            B13 = -Y_nl + self.C_nl.T * (eh * s.mpn)
            out[:n, n + r:] = B13
            out[n + r:, :n] = B13.T
            out[n + r:, n + r:] = -np.diag(eh)
        return 0.5 * (out + out.T)


def lmi_data(system: ScalarNonlinearSystem) -> LMIData:
    """Split ``system`` into the LMI's matrices (linear outputs substituted, eq. 23)."""
    lin = np.array(system.linear_outputs, dtype=bool)
    return LMIData(system.A.astype(float), system.F.astype(float), system.E.astype(float),
                   system.C[lin].astype(float), system.C[~lin].astype(float))


def box_scaling(system: ScalarNonlinearSystem) -> np.ndarray:
    """Half-widths of the operating box (the state scaling of the LMIs)."""
    d = 0.5 * (system.box_upper - system.box_lower)
    return np.where(d > 0, d, 1.0).astype(float)


def lmi_form(data: LMIData) -> str:
    """Which of the paper's LMIs the system's structure gives."""
    if data.r == 0:
        return "(22)"
    if data.p_nl == 0:
        return "(23)"
    return "(8)"


LMI_NAMES = {"(8)": "LMI (8) of Theorem 1", "(22)": "LMI (22) of Corollary 1.1", "(23)": "LMI (23) of Corollary 1.2"}


# ---------------------------------------------------------------------------- cvxpy expression
def _bmat(rows: list[list]) -> cp.Expression:
    return cp.bmat(rows)


@dataclass
class LMIParameters:
    """The cvxpy ``Parameter``s of one region's LMI."""

    uv: cp.Parameter | None
    upv: cp.Parameter | None
    mn: cp.Parameter | None
    mpn: cp.Parameter | None
    sigma: cp.Parameter
    a_shift: cp.Parameter | None = None
    m_shift: cp.Parameter | None = None

    @classmethod
    def create(cls, data: LMIData, shifted: bool) -> "LMIParameters":
        r, pn, n = data.r, data.p_nl, data.n
        return cls(
            cp.Parameter(r, name="uv") if r else None, cp.Parameter(r, name="upv") if r else None,
            cp.Parameter(pn, name="mn") if pn else None, cp.Parameter(pn, name="mpn") if pn else None,
            cp.Parameter(nonneg=True, name="sigma", value=0.0),
            cp.Parameter((n, n), name="a_shift") if shifted and r else None,
            cp.Parameter(pn, name="m_shift") if shifted and pn else None,
        )

    def assign(self, s: SectorData, sigma: float) -> None:
        for name in ("uv", "upv", "mn", "mpn"):
            par = getattr(self, name)
            if par is not None:
                par.value = np.asarray(getattr(s, name), dtype=float)
        if self.a_shift is not None:
            self.a_shift.value = s.a_shift
        if self.m_shift is not None:
            self.m_shift.value = s.m_shift
        self.sigma.value = float(sigma)


def _multiplier_parts(eps, r: int, pn: int):
    """``(eps_f, eps_h)`` of a cvxpy multiplier: a scalar (the paper's) or one per function."""
    if eps.size == 1:
        return eps, eps
    return eps[:r], eps[r:]


def lmi_expression(data: LMIData, P, Y_lin, Y_nl, eps, par: LMIParameters) -> cp.Expression:
    """The LMI matrix as an affine cvxpy expression (DPP: parameter times variable only).

    ``eps`` is a scalar variable (the paper's single S-procedure multiplier) or a vector of
    ``r + p_nl`` (one per function).
    """
    r, pn, pl = data.r, data.p_nl, data.p_lin
    ef, eh = _multiplier_parts(eps, r, pn)
    B11 = P @ data.A + data.A.T @ P + par.sigma * P
    if pl:
        B11 = B11 - Y_lin @ data.C_lin - data.C_lin.T @ Y_lin.T
    if par.a_shift is not None:
        B11 = B11 + P @ par.a_shift + par.a_shift.T @ P
    if r:
        B11 = B11 - data.E.T @ cp.diag(cp.multiply(ef, par.uv)) @ data.E
    if pn:
        B11 = B11 - data.C_nl.T @ cp.diag(cp.multiply(eh, par.mn)) @ data.C_nl
        if par.m_shift is not None:
            K = Y_nl @ cp.diag(par.m_shift) @ data.C_nl
            B11 = B11 - K - K.T
    row1, blocks = [B11], []
    if r:
        B12 = P @ data.F + data.E.T @ cp.diag(cp.multiply(ef, par.upv))
        row1.append(B12)
    if pn:
        B13 = -Y_nl + data.C_nl.T @ cp.diag(cp.multiply(eh, par.mpn))
        row1.append(B13)
    blocks.append(row1)
    if r:
        row = [B12.T, -ef * np.eye(r) if ef.ndim == 0 else -cp.diag(ef)]
        if pn:
            row.append(np.zeros((r, pn)))
        blocks.append(row)
    if pn:
        row = [B13.T]
        if r:
            row.append(np.zeros((pn, r)))
        row.append(-eh * np.eye(pn) if eh.ndim == 0 else -cp.diag(eh))
        blocks.append(row)
    M = _bmat(blocks) if len(blocks) > 1 or len(row1) > 1 else B11
    return 0.5 * (M + M.T)
