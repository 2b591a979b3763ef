"""Periodic coordinates of the switched-gain observer (issue 15): wrapped, not clipped.

A small rotor ``psi' = w, w' = 0`` with the rate measured (``y = w``) and ``psi`` in the box
``[0, 2 pi]``: with a zero gain on ``psi`` the estimate's yaw is predicted exactly (RK4 is exact
for this linear chain), so every expected number below is computed by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.lmi import RegionGain, jacobian_bounds, make_region
from hybobs_opt.observers.switched_gain import SwitchedGainObserver
from hybobs_opt.systems import Polytope, ScalarNonlinearSystem

TWO_PI = 2 * math.pi
DT = 0.01
W_TRUE = 1.0  # rad/s


@pytest.fixture(scope="module")
def rotor() -> ScalarNonlinearSystem:
    box = Polytope.from_box([0.0, -2.0], [TWO_PI, 2.0], ("psi", "w"))
    return ScalarNonlinearSystem(box=box, C=np.array([[0.0, 1.0]]), A=np.array([[0.0, 1.0], [0.0, 0.0]]),
                                 state_names=("psi", "w"), name="rotor")


def _gain(system, lo_deg, hi_deg, index=0, L=((0.0,), (5.0,))) -> RegionGain:
    region = make_region(system, "psi", math.radians(lo_deg), math.radians(hi_deg), index)
    return RegionGain(region=region, L=np.array(L, dtype=float), P=np.eye(system.n), sigma=float("nan"),
                      sigma_max=float("nan"), capped=False, multiplier=float("nan"), lmi_max_eig=float("nan"),
                      bounds=jacobian_bounds(system, region))


def _run(obs: SwitchedGainObserver, x0, steps: int, w: float = W_TRUE):
    obs.reset(np.asarray(x0, dtype=float), q0=0)
    return [obs.step(np.zeros(0), np.array([w])) for _ in range(steps)]


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize("periodic, what", [
    ({"theta": TWO_PI}, "state names"),
    ({2: TWO_PI}, "state indices in [0, 2)"),
    ({-1: TWO_PI}, "state indices in [0, 2)"),
    ({True: TWO_PI}, "state names (str) or indices (int)"),
    ({1.0: TWO_PI}, "state names (str) or indices (int)"),
    ({"psi": 0.0}, "positive finite period"),
    ({"psi": -TWO_PI}, "positive finite period"),
    ({"psi": math.nan}, "positive finite period"),
    ({"psi": math.inf}, "positive finite period"),
    ({"psi": "2 pi"}, "positive finite period"),
    ({"psi": TWO_PI, 0: TWO_PI}, "one period per state"),
    ([("psi", TWO_PI)], "a mapping"),
])
def test_bad_periodic_raises_model_error_naming_periodic(rotor, periodic, what):
    with pytest.raises(ModelError) as info:
        SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, periodic=periodic)
    assert info.value.field == "periodic"
    assert what in info.value.expected


def test_periodic_by_name_index_and_numpy_index_are_the_same(rotor):
    for key in ("psi", 0, np.int64(0)):
        obs = SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, periodic={key: TWO_PI})
        assert obs.periodic == {0: TWO_PI}
    assert SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT).periodic == {}


# --------------------------------------------------------------------------- wrapping
def test_yaw_estimate_crossing_360_deg_reappears_near_0(rotor):
    steps = 50  # 0.5 s at 1 rad/s: 350 deg + 28.648 deg
    x0 = (math.radians(350.0), W_TRUE)
    wrapped = _run(SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, init_samples=1,
                                        periodic={"psi": TWO_PI}), x0, steps)
    clipped = _run(SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, init_samples=1), x0, steps)
    # The first step only stores the sample; 49 steps of 0.01 s integrate.
    expected = math.radians(350.0) + W_TRUE * DT * (steps - 1) - TWO_PI
    assert math.degrees(expected) == pytest.approx(18.07, abs=0.01)
    assert wrapped[-1].x[0] == pytest.approx(expected, abs=1e-12)
    assert clipped[-1].x[0] == TWO_PI  # the old behaviour: stuck at the box's 360 deg edge
    psi = np.array([e.x[0] for e in wrapped])
    assert np.all((psi >= 0.0) & (psi < TWO_PI))
    jump = int(np.argmax(np.diff(psi) < 0))
    assert math.degrees(psi[jump]) > 359.0 and math.degrees(psi[jump + 1]) < 1.0  # one step across 360 deg
    assert np.allclose([e.x[1] for e in wrapped], W_TRUE, atol=1e-12)


def test_other_coordinates_are_still_clipped_and_wrapping_survives_clip_off(rotor):
    x0 = (math.radians(350.0), 1.9)
    # w measured at 3 rad/s, outside its box [-2, 2]: the gain pulls w_hat past 2, which is clipped.
    on = _run(SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, init_samples=1, periodic={"psi": TWO_PI}),
              x0, 40, w=3.0)
    assert on[-1].x[1] == 2.0
    assert 0.0 <= on[-1].x[0] < math.radians(90.0)
    off = _run(SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, init_samples=1, periodic={"psi": TWO_PI},
                                    clip_to_box=False), x0, 40, w=3.0)
    assert off[-1].x[1] > 2.5  # not clipped
    assert 0.0 <= off[-1].x[0] < TWO_PI  # but wrapped


def test_wrap_edges_and_reset_wrap(rotor):
    obs = SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, periodic={"psi": TWO_PI})
    for value, expected in ((-1e-17, 0.0), (TWO_PI, 0.0), (3 * TWO_PI + 0.25, 0.25), (-0.25, TWO_PI - 0.25)):
        got = obs._wrap(np.array([value, 0.0]))[0]
        assert got == pytest.approx(expected, abs=1e-12) and 0.0 <= got < TWO_PI
    obs.reset(np.array([TWO_PI + 0.5, 0.0]))
    assert obs.x[0] == pytest.approx(0.5, abs=1e-12)


def test_difference_is_along_the_circle(rotor):
    obs = SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT, periodic={"psi": TWO_PI})
    x_hat = np.array([[math.radians(1.0), 0.5], [math.radians(359.0), 0.5]])
    x_true = np.array([[math.radians(359.0), 0.25], [math.radians(1.0), 0.25]])
    d = obs.difference(x_hat, x_true)
    assert np.degrees(d[:, 0]) == pytest.approx([2.0, -2.0], abs=1e-9)
    assert d[:, 1] == pytest.approx([0.25, 0.25])
    plain = SwitchedGainObserver(rotor, [_gain(rotor, 0, 360)], DT)
    assert np.array_equal(plain.difference(x_hat, x_true), x_hat - x_true)


# --------------------------------------------------------------------------- the region state machine
def test_region_machine_uses_the_wrapped_value(rotor):
    regs = [_gain(rotor, 0, 100, 0), _gain(rotor, 90, 200, 1)]
    x0 = (math.radians(350.0), W_TRUE)
    wrapped = _run(SwitchedGainObserver(rotor, regs, DT, init_samples=1, periodic={"psi": TWO_PI}), x0, 50)
    clipped = _run(SwitchedGainObserver(rotor, regs, DT, init_samples=1), x0, 50)
    # 350 deg is outside both regions; along the circle it is 10 deg from region 0 ...
    assert wrapped[1].mode == 0 and wrapped[1].info["outside"]
    # ... and once wrapped past 360 deg it is inside region 0.
    assert wrapped[-1].mode == 0 and not wrapped[-1].info["outside"]
    assert math.degrees(wrapped[-1].x[0]) == pytest.approx(18.07, abs=0.01)
    # Clipped at 360 deg the old machine goes to region 1 (160 deg from 200, 260 deg from 100).
    assert clipped[-1].mode == 1 and clipped[-1].info["outside"]


def test_region_of_compares_through_the_nearest_image(rotor):
    regs = [_gain(rotor, -20, 40, 0), _gain(rotor, 30, 120, 1)]
    obs = SwitchedGainObserver(rotor, regs, DT, periodic={"psi": TWO_PI})
    assert obs._region_of(math.radians(350.0), 1) == (0, False)  # 350 deg = -10 deg, inside [-20, 40]
    assert obs._region_of(math.radians(35.0), 1) == (1, False)  # overlap: stay
    assert obs._region_of(math.radians(200.0), 0) == (1, True)  # 80 deg from 120, 140 deg from -20 (= 340)
    assert obs._region_of(math.radians(300.0), 1) == (0, True)  # 40 deg from -20
    plain = SwitchedGainObserver(rotor, regs, DT)
    assert plain._region_of(math.radians(350.0), 1) == (1, True)  # linear distance: 230 deg from 120


def test_default_behaviour_unchanged_without_periodic(rotor):
    regs = [_gain(rotor, 0, 100, 0), _gain(rotor, 90, 200, 1)]
    x0 = (math.radians(80.0), 0.3)
    a = _run(SwitchedGainObserver(rotor, regs, DT, init_samples=1), x0, 120, w=1.5)
    b = _run(SwitchedGainObserver(rotor, regs, DT, init_samples=1, periodic=None), x0, 120, w=1.5)
    c = _run(SwitchedGainObserver(rotor, regs, DT, init_samples=1, periodic={}), x0, 120, w=1.5)
    for ea, eb, ec in zip(a, b, c):
        assert np.array_equal(ea.x, eb.x) and np.array_equal(ea.x, ec.x)
        assert ea.mode == eb.mode == ec.mode
