"""Theorem 5 of paper 004: making the functions monotonic by subtracting a linear term does not help.

Section 4 writes a non-monotonic output as ``h(Cx) = M C x + phi(Cx)`` with ``0 <= phi' <= N - M``
and the observer's error dynamics as ``e' = (A - L M C) e - L (phi(Cx) - phi(Cx_hat))`` (eq. 42),
whose LMI (45) uses ``A - L M C`` and the sector ``[0, N - M]``.  Theorem 5: (45) is equivalent to
(22), because their Schur complements (43) and (44) are the same matrix.  The same holds for the
process functions (``f = U E x + phi``, ``A -> A + F U E``, sector ``[0, V - U]``).

:func:`theorem5_check` shows it on a given system and region: it solves the original and the
transformed LMI (both compiled once, :class:`.ObserverLMI` with ``shifted=True`` for the latter)
and re-checks the algebraic identity (43) = (44) in numpy at random ``P > 0``, ``L``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds, jacobian_bounds
from .lmi_model import LMIData, SectorData, lmi_data
from .observer_lmi import ObserverLMI
from .schedule import SchedulingRegion


def schur_form(data: LMIData, s: SectorData, P: np.ndarray, L_lin: np.ndarray, L_nl: np.ndarray, sigma: float) -> np.ndarray:
    """``B11 + B1r B1r^T`` of the LMI at ``eps = 1``: the left side of (43)/(44) (Schur complement)."""
    B = data.matrix(P, P @ L_lin, P @ L_nl, 1.0, s, sigma)
    n = data.n
    return B[:n, :n] + B[:n, n:] @ B[:n, n:].T


@dataclass(frozen=True)
class SubtractionCheck:
    """Outcome of :func:`theorem5_check`.

    Parameters
    ----------
    original_feasible, shifted_feasible : bool
        Verdicts of the original LMI and of the transformed one (45) at ``sigma``.
    original_status, shifted_status : str
    identity_residual : float
        ``max ||(43) - (44)||_F / ||(44)||_F`` over random ``P > 0, L`` (rounding level).
    shifted_certificate_verified : bool or None
        When the transformed LMI is infeasible: whether its dual certificate passed the numpy check.
    sigma : float
        Decay rate of both LMIs.

    See Also
    --------
    theorem5_check : Returns one.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import theorem5_check
    >>> check = theorem5_check(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140)))
    >>> check.original_feasible, check.shifted_feasible, check.equivalent
    (False, False, True)
    >>> bool(check.identity_residual < 1e-6)
    True
    """

    original_feasible: bool
    shifted_feasible: bool
    original_status: str
    shifted_status: str
    identity_residual: float
    sigma: float
    shifted_certificate_verified: bool | None

    @property
    def equivalent(self) -> bool:
        return self.original_feasible == self.shifted_feasible

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"original_feasible": self.original_feasible, "shifted_feasible": self.shifted_feasible,
                "original_status": self.original_status, "shifted_status": self.shifted_status,
                "identity_residual": self.identity_residual, "sigma": self.sigma, "equivalent": self.equivalent,
                "shifted_certificate_verified": self.shifted_certificate_verified}


def theorem5_check(system: ScalarNonlinearSystem, region: SchedulingRegion | None = None, *, sigma: float = 0.0,
                   bounds: JacobianBounds | None = None, scaling: np.ndarray | None = None, trials: int = 5,
                   seed: int = 0, original: ObserverLMI | None = None) -> SubtractionCheck:
    """Solve the original and the linearly-shifted LMI on the same system (Theorem 5, eqs. 43-46).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    region : SchedulingRegion, optional
        The region (default: the whole operating box); used only when ``bounds`` is not given.
    sigma : float, default 0.0
        Decay rate of both LMIs.
    bounds : JacobianBounds, optional
        Precomputed Jacobian bounds of the region.
    scaling : (n,) array, optional
        State scaling (default: the box half-widths); ignored when ``original`` is given.
    trials : int, default 5
        Random ``(P, L)`` at which the two Schur forms are compared (``identity_residual``).
    seed : int, default 0
        Seed of those random trials.
    original : ObserverLMI, optional
        The compiled original LMI to reuse (default: :meth:`ObserverLMI.compiled`).

    Returns
    -------
    SubtractionCheck
        Both verdicts, their statuses, the largest difference of the two Schur forms at random
        ``(P, L)`` and whether the shifted LMI's certificate was re-checked.

    See Also
    --------
    diagnose : Runs this check with the rest of the diagnosis.
    ObserverLMI : The original LMI.

    Examples
    --------
    Subtracting a linear part does not make the vehicle's LMI feasible on 0-140 deg (Theorem 5):

    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import theorem5_check
    >>> check = theorem5_check(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140)))
    >>> check.original_feasible, check.shifted_feasible
    (False, False)
    """
    from .certificates import certify_infeasible

    b = bounds if bounds is not None else jacobian_bounds(system, region)
    lmi0 = original if original is not None else ObserverLMI.compiled(system, scaling=scaling)
    lmi1 = ObserverLMI.compiled(system, shifted=True, scaling=lmi0.d)
    s0, s1 = lmi0.solve(b, sigma), lmi1.solve(b, sigma)
    cert_ok = None
    if not s1.feasible:
        try:
            cert_ok = certify_infeasible(lmi1, s1).verify()
        except Exception:  # an undecided transformed LMI is reported through its status
            cert_ok = False
    data = lmi_data(system)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(trials):
        G = rng.standard_normal((data.n, data.n))
        P = G @ G.T + data.n * np.eye(data.n)
        Ll = rng.standard_normal((data.n, data.p_lin))
        Ln = rng.standard_normal((data.n, data.p_nl))
        a = schur_form(data, data.sector(b, False), P, Ll, Ln, sigma)
        c = schur_form(data, data.sector(b, True), P, Ll, Ln, sigma)
        worst = max(worst, float(np.linalg.norm(a - c) / max(np.linalg.norm(a), 1e-300)))
    return SubtractionCheck(s0.feasible, s1.feasible, s0.status, s1.status, worst, sigma, cert_ok)
