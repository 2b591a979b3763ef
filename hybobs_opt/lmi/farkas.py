"""Farkas certificates of infeasibility for any cvxpy problem, re-checked in plain numpy.

cvxpy compiles a problem for Clarabel into the conic standard form

    A x + s = b,    s in K = {0}^z x R_+^l x SOC x ... x PSD x ...

and the problem is infeasible exactly when (theorem of alternatives) some ``y`` in the dual cone
``K*`` has ``A^T y = 0`` and ``b^T y < 0``: for a feasible ``x``, ``0 > b^T y = (A x + s)^T y =
s^T y >= 0`` would be a contradiction.  :func:`conic_certificate` solves the compiled problem with
Clarabel and takes its infeasibility ray; :meth:`FarkasCertificate.verify` re-checks the three
conditions with numpy alone (eigenvalues for the PSD blocks, unpacked from Clarabel's scaled upper
triangle), relative to the sizes of ``A``, ``b`` and ``y`` (:data:`~hybobs_opt.tolerances.FARKAS_RTOL`).

What is proven is the infeasibility of the problem exactly as posed, with its margins (a strict
LMI written ``B <= -margin I`` is certified for that margin): the certificate names no more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..results import Certificate
from ..tolerances import FARKAS_MARGIN, FARKAS_RTOL


#: Smallest positive float: the relative residuals of an all-zero ``A`` or ``b`` stay finite.
_TINY: float = float(np.finfo(float).tiny)


@dataclass(frozen=True, eq=False)
class FarkasCertificate(Certificate):
    """``y`` in ``K*`` with ``A^T y = 0`` and ``b^T y < 0`` for the conic form of a cvxpy problem.

    Attributes
    ----------
    problem : str
        What was proven infeasible (for messages).
    A, b : arrays
        The conic data (``A`` as a dense or scipy sparse matrix).
    cones : dict
        ``zero``, ``nonneg`` (ints), ``soc``, ``psd`` (lists of sizes; a PSD size is the matrix order).
    y : array
        The ray, normalised to ``||y||_2 = 1``.
    """

    problem: str
    A: object = field(repr=False)
    b: np.ndarray = field(repr=False)
    cones: dict
    y: np.ndarray = field(repr=False)

    def residuals(self) -> dict[str, float]:
        """``stationarity`` (``||A^T y|| / ||A||``), ``cone`` (worst dual-cone violation) and ``gap``
        (``b^T y / ||b||``, negative for a proof), all for ``||y|| = 1``."""
        y = self.y
        Aty = np.asarray(self.A.T @ y).reshape(-1)
        normA = _norm(self.A)
        stationarity = float(np.linalg.norm(Aty) / max(normA, _TINY))
        nb = float(np.linalg.norm(self.b))
        gap = float(self.b @ y) / max(nb, _TINY)
        return {"stationarity": stationarity, "cone": _dual_cone_violation(y, self.cones), "gap": gap}

    def verify(self) -> bool:
        """The three Farkas conditions, re-checked in numpy (see the module docstring)."""
        if not np.all(np.isfinite(self.y)) or float(np.linalg.norm(self.y)) == 0.0:
            return False
        r = self.residuals()
        return r["stationarity"] <= FARKAS_RTOL and r["cone"] <= FARKAS_RTOL and r["gap"] <= -FARKAS_MARGIN

    #: The theorem the certificate applies (the certificate protocol names one).
    theorem: str = "Farkas lemma (conic theorem of alternatives)"

    @property
    def reason(self) -> str:
        r = self.residuals()
        return (f"Farkas certificate of {self.problem}: y in the dual cone (violation {r['cone']:.2g}) with "
                f"A'y = 0 (relative {r['stationarity']:.2g}) and b'y = {r['gap']:.3g} ||b|| < 0")

    def to_dict(self) -> dict:
        return {"kind": "farkas", "problem": self.problem, "verified": self.verify(), **self.residuals()}


def conic_certificate(problem, what: str) -> FarkasCertificate | None:
    """The Farkas ray of the cvxpy ``problem`` compiled for Clarabel, or ``None`` when Clarabel does
    not report it infeasible (or the problem needs a cone this check does not read)."""
    import cvxpy as cp
    import clarabel
    import scipy.sparse as sp

    data, _, _ = problem.get_problem_data(cp.CLARABEL)
    dims = data["dims"]
    if dims.exp or getattr(dims, "p3d", []) or getattr(dims, "pnd", []):
        return None
    A = sp.csc_matrix(data["A"])
    b = np.asarray(data["b"], dtype=float)
    c = np.asarray(data["c"], dtype=float)
    P = data.get("P")
    P = sp.csc_matrix((A.shape[1], A.shape[1])) if P is None else sp.triu(sp.csc_matrix(P), format="csc")
    cones = []
    if dims.zero:
        cones.append(clarabel.ZeroConeT(dims.zero))
    if dims.nonneg:
        cones.append(clarabel.NonnegativeConeT(dims.nonneg))
    cones += [clarabel.SecondOrderConeT(d) for d in dims.soc]
    cones += [clarabel.PSDTriangleConeT(d) for d in dims.psd]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    sol = clarabel.DefaultSolver(P, c, A, b, cones, settings).solve()
    if str(sol.status) not in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        return None
    y = np.asarray(sol.z, dtype=float)
    ny = float(np.linalg.norm(y))
    if not (np.isfinite(ny) and ny > 0):
        return None
    return FarkasCertificate(what, A, b, {"zero": int(dims.zero), "nonneg": int(dims.nonneg), "soc": list(dims.soc),
                                          "psd": list(dims.psd)}, y / ny)


def verified_farkas(lmi, what: str) -> FarkasCertificate | None:
    """The verified Farkas certificate of ``lmi.problem`` (a compiled LMI object's cvxpy problem at
    its last parameter values, or a cvxpy problem itself), or ``None``."""
    problem = getattr(lmi, "problem", lmi)
    if problem is None or not hasattr(problem, "get_problem_data"):
        return None
    try:
        cert = conic_certificate(problem, what)
    except Exception:  # a compilation or solver crash is no certificate
        return None
    return cert if cert is not None and cert.verify() else None


def _norm(A) -> float:
    try:
        import scipy.sparse as sp

        if sp.issparse(A):
            return float(sp.linalg.norm(A))
    except ImportError:  # pragma: no cover - scipy is a base dependency
        pass
    return float(np.linalg.norm(A))


def _svec_to_matrix(v: np.ndarray, n: int) -> np.ndarray:
    """Clarabel's PSD triangle (upper triangle by columns, off-diagonals times sqrt 2) as a matrix."""
    M = np.zeros((n, n))
    k = 0
    for j in range(n):
        for i in range(j + 1):
            M[i, j] = M[j, i] = v[k] if i == j else v[k] / math.sqrt(2.0)
            k += 1
    return M


def _dual_cone_violation(y: np.ndarray, cones: dict) -> float:
    """Largest violation of ``y in K*`` (the zero cone's dual is free; the others are self-dual)."""
    k = cones["zero"]
    worst = 0.0
    if cones["nonneg"]:
        worst = max(worst, float(-np.min(y[k:k + cones["nonneg"]], initial=0.0)))
        k += cones["nonneg"]
    for d in cones["soc"]:
        t, u = y[k], y[k + 1:k + d]
        worst = max(worst, float(np.linalg.norm(u) - t))
        k += d
    for n in cones["psd"]:
        size = n * (n + 1) // 2
        M = _svec_to_matrix(y[k:k + size], n)
        worst = max(worst, float(-np.linalg.eigvalsh(M)[0]))
        k += size
    return worst


__all__ = ["FARKAS_MARGIN", "FARKAS_RTOL", "FarkasCertificate", "conic_certificate", "verified_farkas"]
