"""Gains of the step-by-step sliding-mode observer (5) of paper 001 (Djemai, Manamanni, Barbot).

Explicit rule (:func:`design_gains`): ``lambda_j = rho * (z_{j+1}^max - z_{j+1}^min)``
for ``j < n`` and ``lambda_n = rho * (f^max - f^min)``, with the ranges over the operating box
and all locations (exact for affine flows) and ``rho`` =
:data:`~hybobs_opt.defaults.SMO_GAIN_MARGIN`.  With the estimate clipped to the same ranges,
``|e_{j+1}| <= z_{j+1}^max - z_{j+1}^min``, so every stage meets its sliding condition with a
reaching rate of at least ``(rho - 1)`` times that width (Theorem 2's "there exists a choice of
lambda_i", made explicit and not tuned per example).
The runtime observer is :mod:`hybobs_opt.observers.sliding_mode`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..systems.canonical_form import ObservabilityForm
from ..defaults import SMO_GAIN_MARGIN

__all__ = ["GainRule", "design_gains", "discretization_band", "reaching_time_bounds"]


@dataclass(frozen=True)
class GainRule:
    """The gains ``lambda_1..lambda_n`` of observer (5) and the bounds they come from.

    Parameters
    ----------
    lambdas : (n,) array
    widths : (n,) array
        Width of the range of ``z_2, ..., z_n`` and of ``f`` (the error bound each stage must
        dominate).
    margin : float
        ``rho`` of the rule ``lambda_j = rho * widths[j]``.
    rule : str
        The rule in words.

    See Also
    --------
    design_gains : computes it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(get_example("double_scroll").build())   # Example 3 of paper 001
    >>> from hybobs_opt.synthesis import design_gains
    >>> gains = design_gains(form, margin=2.0)
    >>> gains.margin, bool((gains.lambdas == 2.0 * gains.widths).all())
    (2.0, True)
    """

    lambdas: np.ndarray
    widths: np.ndarray
    margin: float
    rule: str

    def to_dict(self) -> dict:
        """JSON-ready record of the gains.

        Returns
        -------
        dict
            ``lambdas``, ``widths``, ``margin`` and ``rule``.
        """
        return {"lambdas": self.lambdas.tolist(), "widths": self.widths.tolist(), "margin": self.margin, "rule": self.rule}


def design_gains(form: ObservabilityForm, margin: float = SMO_GAIN_MARGIN) -> GainRule:
    """Gains of observer (5) from the state and derivative bounds (explicit rule, see the module).

    ``lambda_j = margin * (z_{j+1}^max - z_{j+1}^min)`` for ``j < n`` and
    ``lambda_n = margin * (f^max - f^min)``.

    Parameters
    ----------
    form : ObservabilityForm
        The automaton in the canonical form (4) of paper 001, with its state and derivative ranges.
    margin : float, default SMO_GAIN_MARGIN
        Factor ``> 1`` on each range width.

    Returns
    -------
    GainRule
        The gains ``lambda_j`` with the widths they come from.

    Raises
    ------
    ModelError
        If ``margin <= 1`` (the sliding condition needs ``lambda_j`` above the error bound).

    See Also
    --------
    GainRule : what it returns.
    reaching_time_bounds : when each stage reaches its layer.
    hybobs_opt.observers.SlidingModeObserver : the observer (5).

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(get_example("double_scroll").build())   # Example 3 of paper 001
    >>> from hybobs_opt.synthesis import design_gains
    >>> gains = design_gains(form)                     # margin 1.5 over the range widths
    >>> gains.lambdas.round(3), gains.widths.round(3)
    (array([  42.857,  385.714, 1022.449]), array([ 28.571, 257.143, 681.633]))
    """
    if not (np.isfinite(margin) and margin > 1.0):
        raise ModelError("margin", "a finite gain margin above 1 (lambda_j must exceed the error bound)", repr(margin))
    widths = np.append(form.z_upper[1:] - form.z_lower[1:], form.f_upper - form.f_lower)
    widths = np.maximum(widths, np.finfo(float).tiny)
    rule = (f"lambda_j = {margin:g} x (range width of z_(j+1)) for j < n, lambda_n = {margin:g} x (range width of z_n' = f_q) "
            f"over the operating box and all locations ({form.f_bound_method} bound of f)")
    return GainRule(margin * widths, widths, float(margin), rule)


def discretization_band(form: ObservabilityForm, Ts: float) -> np.ndarray:
    """Error band of each canonical state after convergence, noise-free: ``j h D_j``.

    Stage ``j``'s auxiliary state is a ``(j-1)``-fold backward difference of ``y`` (lag
    ``(j-1) h / 2``) and the estimate adds one Euler step, so its error is at most about
    ``(j + 1) / 2 * h * D_j <= j h D_j`` with ``D_j`` the bound of ``z_j' `` (``max |z_{j+1}|``,
    and ``max |f|`` for ``j = n``) over the operating box.

    Parameters
    ----------
    form : ObservabilityForm
        The automaton in the canonical form (4), with its state and derivative ranges.
    Ts : float
        Sampling period ``h``.

    Returns
    -------
    (n,) ndarray
        The band of each canonical state ``z_j``.

    See Also
    --------
    reaching_time_bounds : the transient before it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(get_example("double_scroll").build())   # Example 3 of paper 001
    >>> from hybobs_opt.synthesis import discretization_band
    >>> discretization_band(form, Ts=0.01).round(4)    # error band of z1, z2, z3 at 100 Hz
    array([ 0.1429,  2.5714, 10.2245])
    """
    n = form.n
    D = np.empty(n)
    for j in range(n - 1):
        D[j] = max(abs(form.z_lower[j + 1]), abs(form.z_upper[j + 1]))
    D[n - 1] = max(abs(form.f_lower), abs(form.f_upper))
    return np.arange(1, n + 1) * float(Ts) * D


def reaching_time_bounds(gains: GainRule, initial_error: float) -> np.ndarray:
    """Upper bounds on the times at which stages ``1..n`` of observer (5) reach their layers.

    Stage 1 starts at ``|e_1(0)| = initial_error`` and approaches at rate
    ``lambda_1 - widths[0] = (rho - 1) widths[0]`` at least; stage ``j > 1`` starts once stage
    ``j - 1`` slides, with an error of at most ``widths[j - 1]`` (clipping), and approaches at
    rate ``(rho - 1) widths[j]``.  (Each stage also waits :data:`~hybobs_opt.defaults.SMO_SLIDING_HOLD` samples,
    not included.)

    Returns
    -------
    (n,) ndarray
        Upper bounds (seconds) on the time stage ``j`` reaches its layer.

    See Also
    --------
    design_gains : the gains.
    discretization_band : the error band after convergence.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import observability_form
    >>> form = observability_form(get_example("double_scroll").build())   # Example 3 of paper 001
    >>> from hybobs_opt.synthesis import design_gains, reaching_time_bounds
    >>> reaching_time_bounds(design_gains(form), initial_error=1.0).round(4)
    array([0.07  , 0.2922, 1.0467])
    """
    rate = gains.lambdas - gains.widths
    out = np.empty(gains.lambdas.size)
    t = abs(float(initial_error)) / rate[0]
    out[0] = t
    for j in range(1, gains.lambdas.size):
        t += gains.widths[j - 1] / rate[j]
        out[j] = t
    return out
