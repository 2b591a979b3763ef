"""Weights and the stacked residual of the moving-horizon cost (paper 002, eq. 10).

The cost of eq. (10) (Bemporad, Ferrari-Trecate & Morari, 2000) with the optional terms of
Ferrari-Trecate, Mignone & Morari (2002) is a norm of one stacked residual, affine in the MLD
variables ``v`` and in the window data: ``r = R v + SY Y + SU U + SX x_bar + r0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import real_array
from ..errors import ModelError
from .mld import MLDEncoding

__all__ = ["StackedResidual", "stacked_residual", "weight_matrix"]


def weight_matrix(W, dim: int, name: str) -> np.ndarray | None:
    """``None`` or a ``(dim, dim)`` weight matrix from a scalar, a vector (diagonal) or a matrix."""
    if W is None:
        return None
    arr = real_array(W, name, f"a scalar, a length-{dim} vector or a ({dim}, {dim}) matrix")
    if arr.ndim == 0:
        arr = np.full(dim, float(arr))
    if arr.ndim == 1:
        if arr.size != dim:
            raise ModelError(name, f"a length-{dim} vector (diagonal weight)", f"length {arr.size}")
        if np.any(arr < 0):  # a negative weight is a typo: its sign never matters in a norm
            raise ModelError(name, "nonnegative diagonal weights", f"{arr.tolist()}")
        arr = np.diag(arr)
    if arr.shape != (dim, dim):
        raise ModelError(name, f"a ({dim}, {dim}) matrix", f"shape {arr.shape}")
    if np.any(np.diag(arr) < 0):  # W and -W weigh alike: a negative diagonal entry is a sign typo
        raise ModelError(name, "a weight matrix with a nonnegative diagonal", f"diagonal {np.diag(arr).tolist()}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(name, "finite entries", "NaN or Inf")
    if not np.any(arr):
        raise ModelError(name, "a non-zero weight (use None to drop the term)", "all zeros")
    return arr


@dataclass(frozen=True, eq=False)
class StackedResidual:
    """Stacked weighted residual ``r = R v + SY Y + SU U + SX x_bar + SP P + r0`` and its blocks.

    ``P`` are an extension's parameters (``SP`` is ``None`` or has no columns without one); the
    rows come from the CasADi formulation (:class:`~hybobs_opt.mhe.formulation.MHEFormulation`)
    or from :func:`stacked_residual`.
    """

    R: np.ndarray
    SY: np.ndarray
    SU: np.ndarray
    SX: np.ndarray
    r0: np.ndarray
    blocks: tuple[tuple[str, slice], ...]
    SP: np.ndarray | None = None

    def offset(self, Y: np.ndarray, U: np.ndarray, xbar: np.ndarray, P: np.ndarray | None = None) -> np.ndarray:
        """``r - R v``: the residual's offset for the window data (and the extension's parameters ``P``)."""
        out = self.SY @ Y + self.SU @ U + self.SX @ xbar + self.r0
        if self.SP is not None and self.SP.shape[1]:
            out = out + self.SP @ P
        return out


def stacked_residual(enc: MLDEncoding, Wy: np.ndarray, Ww: np.ndarray | None, Wa: np.ndarray | None) -> StackedResidual:
    """The weighted residual of eq. (10) with the optional terms, as rows on the MLD variables ``v``.

    Output block ``W_y (y(k) - y^(k))`` for every window step, then (with ``Ww``) the disturbance
    block ``W_w w(k)`` and (with ``Wa``) the arrival block ``W_a (x(t-T+1) - x_bar)``
    (Ferrari-Trecate, Mignone & Morari 2002).
    """
    sysm, T = enc.system, enc.T
    n, m, p = sysm.n, sysm.m, sysm.p
    hx, cx = enc.x_scale
    nv = enc.n_vars
    Wyb = np.kron(np.eye(T), Wy)
    R = [-Wyb @ enc.Ymap]
    SY = [Wyb]
    SU = [-Wyb @ enc.YU]
    SX = [np.zeros((T * p, n))]
    r0 = [-Wyb @ enc.Yoff]
    blocks = [("output", slice(0, T * p))]
    row = T * p
    if Ww is not None and T > 1:
        Rw = np.zeros(((T - 1) * n, nv))
        Rw[:, enc.slices["omega"]] = np.kron(np.eye(T - 1), Ww @ np.diag(hx))
        R.append(Rw)
        SY.append(np.zeros(((T - 1) * n, T * p)))
        SU.append(np.zeros(((T - 1) * n, T * m)))
        SX.append(np.zeros(((T - 1) * n, n)))
        r0.append(np.zeros((T - 1) * n))
        blocks.append(("disturbance", slice(row, row + (T - 1) * n)))
        row += (T - 1) * n
    if Wa is not None:
        Ra = np.zeros((n, nv))
        Ra[:, enc.slices["xi0"]] = Wa @ np.diag(hx)
        R.append(Ra)
        SY.append(np.zeros((n, T * p)))
        SU.append(np.zeros((n, T * m)))
        SX.append(-Wa)
        r0.append(Wa @ cx)
        blocks.append(("arrival", slice(row, row + n)))
    return StackedResidual(np.vstack(R), np.vstack(SY), np.vstack(SU), np.vstack(SX), np.concatenate(r0), tuple(blocks))
