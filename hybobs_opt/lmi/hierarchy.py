"""A hierarchy of sufficient conditions for a constant observer gain, weakest claim first.

For one region of the operating box, three conditions are tried in order; each one's feasible set
contains the previous one's, so an infeasible condition rules out everything before it:

1. ``"paper"`` -- LMI (8), (22) or (23) of paper 004 with the paper's single S-procedure multiplier
   (Theorem 1, Corollaries 1.1-1.2);
2. ``"per_function"`` -- the same LMI with one multiplier per nonlinear function (each sector
   condition weighed on its own);
3. ``"polytopic"`` -- one quadratic Lyapunov function ``e^T P e`` for every vertex of the box of
   Jacobian slopes (:mod:`.polytopic`): the least conservative constant-gain condition with a
   quadratic Lyapunov function.

A feasible condition comes with its gain ``L`` and the decay rate that ``(P, L)`` proves on every
vertex of the Jacobian box, recomputed in numpy (:func:`.polytopic.vertex_decay`; every ``(P, L)``
of conditions 1-2 also satisfies 3).  An infeasible condition comes with a dual certificate that
``verify()`` re-checks in numpy.  What is proven is named exactly: "no constant gain satisfies
LMI (8) ... nor the polytopic condition" rules out every constant gain *with a quadratic Lyapunov
function*, not every constant gain; only :mod:`.impossibility` proves statements about every gain.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..defaults import POLYTOPIC_MAX_VERTICES
from ..errors import HybobsError, ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds, jacobian_bounds
from .certificates import certify_infeasible
from .lmi_model import LMI_NAMES
from .observer_lmi import ObserverLMI
from .polytopic import PolytopicLMI, vertex_decay, vertex_matrices, vertex_slopes
from .schedule import SchedulingRegion

#: The conditions, in the order of the hierarchy.
CONDITIONS = ("paper", "per_function", "polytopic")


def condition_name(key: str, form: str) -> str:
    """Human name of a condition (``form`` is ``"(8)"``, ``"(22)"`` or ``"(23)"``)."""
    lmi = LMI_NAMES.get(form, f"LMI {form}")
    return {"paper": f"{lmi} (one S-procedure multiplier, as in the paper)",
            "per_function": f"{lmi} with one S-procedure multiplier per function",
            "polytopic": "the polytopic condition (one quadratic Lyapunov function on every vertex of the Jacobian box)"}[key]


@dataclass(frozen=True)
class ConditionResult:
    """The verdict of one condition of the hierarchy on one region.

    Parameters
    ----------
    key : str
        ``"paper"``, ``"per_function"`` or ``"polytopic"``.
    name : str
    feasible : bool
    status : str
        The solver's status (``"implied"`` when an earlier condition's solution is used).
    L, P : arrays or None
        Gain and Lyapunov matrix (model coordinates) of a feasible condition.
    sigma_verified : float or None
        Decay rate ``(P, L)`` proves on every vertex of the Jacobian box, recomputed in numpy.
    certificate : object or None
        For an infeasible condition: the dual certificate (``verify()`` re-checks it in numpy);
        :class:`.certificates.InfeasibilityCertificate` for the multiplier LMIs,
        :class:`.polytopic.PolytopicCertificate` for the polytopic one.
    implied_by : str or None
        Feasible because an earlier (stronger) condition is.
    seconds : float
    skipped : str
        Why the condition was not solved or not decided (empty otherwise).
    solution : LMISolution, PolytopicSolution or None
        The solve behind the verdict.

    See Also
    --------
    condition_hierarchy : Returns one per condition in a HierarchyResult.
    HierarchyResult.get : One condition's result by key.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import condition_hierarchy
    >>> result = condition_hierarchy(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80)))
    >>> paper = result.get("paper")
    >>> paper.name  # doctest: +ELLIPSIS
    'LMI (23) of Corollary 1.2 (one S-procedure multiplier, as in the paper)'
    >>> paper.feasible, paper.status, paper.L.shape
    (True, 'optimal', (4, 2))
    """

    key: str
    name: str
    feasible: bool
    status: str
    L: np.ndarray | None = None
    P: np.ndarray | None = None
    sigma_verified: float | None = None
    certificate: object | None = field(default=None, repr=False)
    implied_by: str | None = None
    seconds: float = 0.0
    skipped: str = ""
    solution: object | None = field(default=None, repr=False)

    @property
    def verified(self) -> bool:
        """Infeasible with a certificate that passes the numpy re-check."""
        cert = self.certificate
        if self.feasible or cert is None:
            return False
        return bool(getattr(cert, "structural_verified", False) or cert.verify())

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        out = {"condition": self.key, "name": self.name, "feasible": self.feasible, "status": str(self.status),
               "implied_by": self.implied_by, "seconds": self.seconds}
        if self.skipped:
            out["skipped"] = self.skipped
        if self.feasible:
            out.update(L=self.L.tolist(), P=self.P.tolist(), sigma_verified=self.sigma_verified)
        else:
            out["certificate_verified"] = self.verified
            if self.certificate is not None:
                out["certificate"] = self.certificate.to_dict()
        return out


@dataclass(frozen=True)
class HierarchyResult:
    """All conditions of the hierarchy on one region, and what they prove together.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system.
    region : SchedulingRegion or None
        The region (``None`` for the whole operating box).
    form : str
        The paper's LMI for the system: ``"(8)"``, ``"(22)"`` or ``"(23)"``.
    conditions : tuple of ConditionResult
        One per condition of :data:`CONDITIONS`, in that order.
    seconds : float
        Wall time of the hierarchy.

    See Also
    --------
    condition_hierarchy : Returns one.
    ConditionResult : One condition's verdict.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import condition_hierarchy
    >>> result = condition_hierarchy(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140)))
    >>> [(c.key, c.feasible, c.status) for c in result.conditions]  # doctest: +NORMALIZE_WHITESPACE
    [('paper', False, 'infeasible'), ('per_function', False, 'infeasible'),
     ('polytopic', False, 'infeasible')]
    >>> result.feasible, result.strongest_infeasible
    (False, 'polytopic')
    >>> print(result.claim("psi in [0, 140] deg"))  # doctest: +ELLIPSIS
    No constant gain satisfies LMI (23) of Corollary 1.2 (one S-procedure ...
    """

    system: ScalarNonlinearSystem = field(repr=False)
    region: SchedulingRegion | None
    form: str
    conditions: tuple[ConditionResult, ...]
    seconds: float

    def get(self, key: str) -> ConditionResult:
        """The result of condition ``key``.

        Parameters
        ----------
        key : {"paper", "per_function", "polytopic"}
            The condition (:data:`CONDITIONS`).

        Returns
        -------
        ConditionResult
            The result of condition ``key``.

        Raises
        ------
        KeyError
            If no condition has that key.
        """
        for c in self.conditions:
            if c.key == key:
                return c
        raise KeyError(key)

    @property
    def feasible_condition(self) -> str | None:
        """The first (most conservative) condition that is feasible, or ``None``."""
        return next((c.key for c in self.conditions if c.feasible), None)

    @property
    def feasible(self) -> bool:
        return self.feasible_condition is not None

    @property
    def strongest_infeasible(self) -> str | None:
        """The last condition of the leading run of *certified* infeasible ones.

        Infeasibility of a condition with a verified certificate rules out the ones before it;
        the claim stops at the first condition that is feasible, uncertified or skipped.
        """
        out = None
        for c in self.conditions:
            if c.verified:
                out = c.key
            else:
                break
        return out

    @property
    def gain(self) -> ConditionResult | None:
        """The feasible condition whose gain is recommended (the first feasible one)."""
        return next((c for c in self.conditions if c.feasible), None)

    def claim(self, where: str, with_gain: bool = True) -> str:
        """What the hierarchy proves on the region (``where`` names it, e.g. ``"theta in [0, 1]"``).

        Parameters
        ----------
        where : str
            Text naming the region in the claim.
        with_gain : bool, default True
            Quote the feasible condition's gain and rate (its first feasible point, at decay rate 0
            without a gain bound); ``False`` when a designed gain is stated elsewhere.

        Returns
        -------
        str
            What the hierarchy proves on the region named by ``where``.
        """
        strongest = self.strongest_infeasible
        feas = self.gain
        parts = []
        if strongest is not None:
            keys = CONDITIONS[:CONDITIONS.index(strongest) + 1]
            names = [condition_name(k, self.form) for k in keys]
            listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " nor " + names[-1]
            parts.append(f"No constant gain satisfies {listed} on {where}: "
                         + ("it is" if len(names) == 1 else "each is") + " proven infeasible by a dual certificate "
                         "re-checked in numpy.")
            if strongest == "polytopic":
                parts.append("This rules out every constant gain with a quadratic Lyapunov function for the Jacobian "
                             "box; it does not prove that no constant gain makes the error converge.")
        if feas is not None:
            how = "" if feas.implied_by is None else f" (implied by {feas.implied_by})"
            if not with_gain:
                parts.append(f"Without a gain bound, {condition_name(feas.key, self.form)} is feasible{how}.")
            else:
                rate = "" if feas.sigma_verified is None else (
                    f", decay rate {feas.sigma_verified:.4g} 1/s proven on every vertex of the Jacobian box (numpy re-check)")
                parts.append(f"A constant gain exists on {where}: {condition_name(feas.key, self.form)} is feasible{how}"
                             f"{rate}; L = {np.round(feas.L, 6).tolist()}.")
        elif strongest != "polytopic":
            undecided = [c for c in self.conditions if not c.feasible and not c.verified]
            if undecided:
                c = undecided[0]
                parts.append(f"{condition_name(c.key, self.form)} was not decided ({c.skipped or c.status}): no claim "
                             "beyond it is made.")
        return " ".join(parts)

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"lmi": self.form, "conditions": [c.to_dict() for c in self.conditions],
                "feasible_condition": self.feasible_condition, "strongest_infeasible": self.strongest_infeasible,
                "seconds": self.seconds}


def _vertex_rate(system: ScalarNonlinearSystem, bounds: JacobianBounds, P, L) -> float:
    from .lmi_model import lmi_data

    data = lmi_data(system)
    lin = np.array(system.linear_outputs, dtype=bool)
    cols = np.concatenate([np.nonzero(lin)[0], np.nonzero(~lin)[0]]).astype(int)
    As, Cs = vertex_matrices(data, vertex_slopes(bounds))
    return vertex_decay(P, L[:, cols], As, Cs)


def _certificate(lmi, sol, region_text: str | None = None) -> tuple[object | None, str]:
    """``(certificate or None, reason it is missing)`` for a solve that was not feasible."""
    if isinstance(lmi, PolytopicLMI):
        cert = lmi.certify(sol)
        return cert, "" if cert is not None else f"no certificate verified ({sol.status})"
    try:
        cert = certify_infeasible(lmi, sol, region_text=region_text)
    except HybobsError as exc:  # undecided: neither a checked point nor a verified certificate
        return None, str(exc)
    if cert.verify() or cert.structural_verified:
        return cert, ""
    return None, f"no certificate verified ({sol.status})"


def condition_hierarchy(system: ScalarNonlinearSystem, region: SchedulingRegion | None = None, *,
                        bounds: JacobianBounds | None = None, scaling: np.ndarray | None = None,
                        sigma: float = 0.0, region_text: str | None = None) -> HierarchyResult:
    """Run the three conditions of the module docstring on ``region`` (default: the whole box).

    Each condition is solved at decay rate ``sigma`` (default 0: infeasibility there rules out every
    rate) without a gain bound, so a certificate covers every gain.  Once a condition is feasible,
    the later ones are feasible by implication (their ``status`` is ``"implied"``, their gain the
    same).  An undecided solve (no certificate verified, no checked point) ends the claim there.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    region : SchedulingRegion, optional
        The region; ``None`` means the whole operating box.  Used only to compute ``bounds``.
    bounds : JacobianBounds, optional
        Precomputed Jacobian bounds of the region (default: :func:`.bounds.jacobian_bounds`).
    scaling : (n,) array, optional
        State scaling of the LMIs (default: the box half-widths).
    sigma : float, default 0.0
        Decay rate at which every condition is solved.
    region_text : str, optional
        How the region is named in the certificates' messages.

    Returns
    -------
    HierarchyResult
        One :class:`ConditionResult` per condition (``"paper"``, ``"per_function"``,
        ``"polytopic"``), each with its gain or its re-checked certificate.

    See Also
    --------
    ObserverLMI : The paper's LMI, the first condition.
    PolytopicLMI : The vertex condition, the last one.
    diagnose : Runs the hierarchy with the rest of the diagnosis.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import condition_hierarchy
    >>> result = condition_hierarchy(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140)))
    >>> [(c.key, c.feasible) for c in result.conditions]
    [('paper', False), ('per_function', False), ('polytopic', False)]
    >>> result.feasible
    False
    """
    if not isinstance(system, ScalarNonlinearSystem):
        raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
    t0 = time.perf_counter()
    bounds = bounds if bounds is not None else jacobian_bounds(system, region)
    results: list[ConditionResult] = []
    form = ObserverLMI.compiled(system, scaling=scaling).form
    feasible: ConditionResult | None = None
    for key in CONDITIONS:
        name = condition_name(key, form)
        if feasible is not None:
            results.append(ConditionResult(key, name, True, "implied", feasible.L, feasible.P, feasible.sigma_verified,
                                           implied_by=feasible.key))
            continue
        t1 = time.perf_counter()
        if key == "per_function" and system.r + sum(not lin for lin in system.linear_outputs) <= 1:
            prev = results[-1]
            results.append(ConditionResult(key, name, prev.feasible, "same as paper (one function)", prev.L, prev.P,
                                           prev.sigma_verified, prev.certificate, "paper" if prev.feasible else None,
                                           solution=prev.solution))
            continue
        try:
            lmi = design_lmi(system, key, scaling=scaling)
        except ModelError as exc:  # the polytopic condition beyond POLYTOPIC_MAX_VERTICES vertices
            results.append(ConditionResult(key, name, False, "skipped", skipped=f"not built: {exc} (at most {POLYTOPIC_MAX_VERTICES} vertices)"))
            continue
        sol = lmi.solve(bounds, sigma)
        if sol.feasible:
            rate = _vertex_rate(system, bounds, sol.P, sol.L)
            feasible = ConditionResult(key, name, True, sol.status, sol.L, sol.P, rate, seconds=time.perf_counter() - t1,
                                       solution=sol)
            results.append(feasible)
            continue
        cert, skipped = _certificate(lmi, sol, region_text)
        results.append(ConditionResult(key, name, False, sol.status, certificate=cert, skipped=skipped,
                                       seconds=time.perf_counter() - t1, solution=sol))
    return HierarchyResult(system, bounds.region, form, tuple(results), time.perf_counter() - t0)


def design_lmi(system: ScalarNonlinearSystem, key: str, *, gain_bound: float | None = None,
               scaling: np.ndarray | None = None):
    """The compiled problem of condition ``key`` (with the gain bound), for a decay-rate search."""
    if key not in CONDITIONS:
        raise ModelError("condition", f"one of {CONDITIONS}", repr(key))
    if key == "polytopic":
        return PolytopicLMI.compiled(system, gain_bound=gain_bound, scaling=scaling)
    return ObserverLMI.compiled(system, gain_bound=gain_bound, scaling=scaling,
                                multipliers="single" if key == "paper" else "per_function")


def verified_rate(system: ScalarNonlinearSystem, bounds: JacobianBounds, P: np.ndarray, L: np.ndarray) -> float:
    """Decay rate ``(P, L)`` proves on every vertex of the Jacobian box ``bounds`` (numpy)."""
    return _vertex_rate(system, bounds, P, L)
