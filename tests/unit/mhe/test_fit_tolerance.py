"""The MHE's model-fit test (issue 16): a certified optimum that misses a window's output by more
than ``fit_tolerance`` proves that no trajectory of the model explains the window.

Before it, one output sample ten times the run's largest (inside the model's output range) was fitted
as well as the model allowed and the optimum flagged ``observable``, omega_m 117 rad/s off.
"""

import numpy as np
import pytest

from hybobs_opt.contract import FALLBACK, OBSERVABLE
from hybobs_opt.defaults import INNOVATION_MARGIN
from hybobs_opt.errors import ModelError
from hybobs_opt.mhe import MHEObserver
from hybobs_opt.systems.ranges import output_range

A, B = 990, 1030  # a stretch of the powertrain3 scenario through the backlash
OA, OB = 0, 40  # a stretch whose windows are all observable on the clean data

# plant_trace: the powertrain3 plant and its scenario (conftest.py)


def test_default_tolerance_is_the_innovation_margin_of_the_output_range(plant_trace):
    plant, _ = plant_trace
    lo, hi = output_range(plant)
    np.testing.assert_allclose(MHEObserver(plant, 3).fit_tolerance, INNOVATION_MARGIN * (hi - lo))


def test_an_outlier_no_trajectory_fits_is_never_flagged_observable(plant_trace):
    plant, tr = plant_trace
    U, Y, X = tr.u[OA:OB], tr.y[OA:OB].copy(), tr.x[OA:OB]
    k = 20
    Y[k] = 10 * np.max(np.abs(tr.y))  # inside the model's output range (0..600 rad/s)
    lo, hi = output_range(plant)
    assert lo[0] <= Y[k, 0] <= hi[0]
    trace = MHEObserver(plant, 3, x0=X[0]).run(U, Y)
    clean = np.asarray(MHEObserver(plant, 3, x0=X[0]).run(U, tr.y[OA:OB]).flags)
    flags = np.asarray(trace.flags)
    # every window holding the outlier (k .. k + T - 1) falls back, with the reason
    assert np.all(flags[k:k + 3] == FALLBACK)
    err = np.abs(trace.x_hat - X)
    assert not np.any((flags == OBSERVABLE) & (err > 1e-3 * (1 + np.abs(X))).any(axis=1))
    # and the observer recovers once the outlier has left the window (a few steps of warm start)
    assert np.array_equal(flags[k + 3 + 2:], clean[k + 3 + 2:]) and np.any(clean[k + 3 + 2:] == OBSERVABLE)


def test_noisy_data_fit_within_a_noise_level_tolerance(plant_trace):
    plant, tr = plant_trace
    rng = np.random.default_rng(0)
    Y = tr.y[A:B] + 0.01 * rng.normal(size=(B - A, 1))
    obs = MHEObserver(plant, 3, x0=tr.x[A], fit_tolerance=0.05)
    reasons = [e.info.get("reason", "") for e in (obs.step(u, y) for u, y in zip(tr.u[A:B], Y))]
    assert not any("no trajectory of the model fits" in r for r in reasons)
    tight = MHEObserver(plant, 3, x0=tr.x[A], fit_tolerance=1e-4)  # far below the noise
    reasons = [e.info.get("reason", "") for e in (tight.step(u, y) for u, y in zip(tr.u[A:B], Y))]
    assert sum("no trajectory of the model fits" in r for r in reasons) > (B - A) // 2


@pytest.mark.parametrize("bad", [-1.0, 0.0, np.inf, 1j, "0.1", True, [0.1, 0.2]])
def test_a_bad_fit_tolerance_is_a_model_error(plant_trace, bad):
    with pytest.raises(ModelError, match="fit_tolerance"):
        MHEObserver(plant_trace[0], 3, fit_tolerance=bad)
