"""A sensor fault never enters the switched-gain observer's state (issue 16).

Before: after one sample ``y = 1e12`` the piston's switched-gain observer ended 68 mm/s off while
flagging ``observable``.  Now a sample outside the range the model's outputs can take on the
operating box, by more than ``RANGE_MARGIN`` of its width, is flagged ``fallback`` and the step
is open loop; plausible noise is still used.  The reference is the same observer on the clean
record (no shared code with the range check).
"""

import numpy as np
import pytest

from hybobs_opt.defaults import RANGE_MARGIN
from hybobs_opt.observers.switched_gain import SwitchedGainObserver
from hybobs_opt.studies import get_example
from hybobs_opt.studies.paper004_nonmonotonic.scenarios import cached_design

FAULT_STEP = 1500


@pytest.fixture(scope="module")
def piston_run():
    design = cached_design("magnetic_piston")
    system = design.system
    trace = get_example("magnetic_piston").scenario(system)
    dt = float(trace.t[1] - trace.t[0])

    def run(Y, output_range="model"):
        obs = SwitchedGainObserver(system, design.regions, dt)
        if output_range is None:
            obs.output_range = None
        obs.reset(trace.x[0] + np.array([4.0, 0.0, 0.0]))
        ot = obs.run(trace.u, Y)
        return ot, obs.difference(ot.x_hat, trace.x)

    return system, trace, run


def test_the_range_is_what_the_sensors_can_produce(piston_run):
    system, trace, _ = piston_run
    lo, hi = SwitchedGainObserver(system, cached_design("magnetic_piston").regions, 1e-3).output_range
    # our own dense evaluation of the sensor curves along the stroke (the outputs depend on z only)
    z = np.linspace(system.box_lower[0], system.box_upper[0], 20001)
    X = np.column_stack([z, np.zeros_like(z), np.zeros_like(z)])
    Y = system.output(X)
    np.testing.assert_allclose(lo, Y.min(axis=0), atol=1e-3 * np.ptp(Y, axis=0).max())
    np.testing.assert_allclose(hi, Y.max(axis=0), atol=1e-3 * np.ptp(Y, axis=0).max())
    width = hi - lo
    assert np.all((trace.y >= lo - 1e-6 * width) & (trace.y <= hi + 1e-6 * width))  # the scenario stays inside


@pytest.mark.parametrize("value", [1e12, -1e300, 50.0])
def test_a_faulty_sample_is_flagged_fallback_and_does_not_enter_the_state(piston_run, value):
    system, trace, run = piston_run
    clean_ot, clean_err = run(trace.y)
    Y = trace.y.copy()
    Y[FAULT_STEP, 0] = value
    ot, err = run(Y)
    assert ot.flags[FAULT_STEP] == "fallback"
    assert "outside the model's range" in ot.info[FAULT_STEP]["reason"]
    assert sum(f == "fallback" for f in ot.flags) == sum(f == "fallback" for f in clean_ot.flags) + 1
    # one open-loop step at 1 kHz: the run ends where the clean run ends
    np.testing.assert_allclose(err[-1], clean_err[-1], rtol=1e-3, atol=1e-6)
    assert abs(err[-1, 1]) < 1.0  # mm/s


def test_without_the_check_the_fault_corrupts_the_estimate(piston_run):
    """The regression this guards: the same fault with the range check switched off."""
    _, trace, run = piston_run
    Y = trace.y.copy()
    Y[FAULT_STEP, 0] = 1e12
    ot, err = run(Y, output_range=None)
    assert ot.flags[FAULT_STEP] != "fallback"
    assert not np.all(np.abs(err[-1]) < [0.5, 5.0, np.inf][: err.shape[1]])  # ends off: mm, mm/s


def test_noise_inside_the_margin_is_used(piston_run):
    system, trace, run = piston_run
    lo, hi = SwitchedGainObserver(system, cached_design("magnetic_piston").regions, 1e-3).output_range
    Y = trace.y.copy()
    Y[FAULT_STEP, 0] = hi[0] + 0.4 * RANGE_MARGIN * (hi[0] - lo[0])  # beyond the range, inside the margin
    ot, _ = run(Y)
    assert ot.flags[FAULT_STEP] != "fallback"
