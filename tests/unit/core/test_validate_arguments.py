"""The scalar, switch and class checks of hybobs_opt._validate used by the observers' constructors (issue 16)."""

import numpy as np
import pytest

from hybobs_opt._validate import as_flag, as_instance, as_positive
from hybobs_opt.errors import ModelError


@pytest.mark.parametrize("value", [1, 0.5, np.float32(0.25), np.float64(2.0), np.int64(3), 1e-300])
def test_as_positive_accepts_real_positive_scalars(value):
    out = as_positive(value, "dt")
    assert type(out) is float and out == float(value)


@pytest.mark.parametrize("value", [True, np.bool_(True), 0.1 + 0.1j, complex(0.1, 0.0), np.array([0.1]), np.array(0.1), [0.1],
                                   "0.1", b"1", None, object(), 0, -1.0, float("nan"), float("inf")])
def test_as_positive_refuses_what_is_not_a_positive_finite_real(value):
    with pytest.raises(ModelError, match=r"^dt: expected a positive sampling period") as info:
        as_positive(value, "dt", "a positive sampling period")
    assert info.value.field == "dt"


def test_as_positive_none_only_when_allowed():
    assert as_positive(None, "max_time_step", allow_none=True) is None
    with pytest.raises(ModelError, match="or None"):
        as_positive(-1.0, "max_time_step", allow_none=True)


@pytest.mark.parametrize("value", [True, False, np.bool_(True), np.bool_(False)])
def test_as_flag_accepts_bools(value):
    assert as_flag(value, "project") is bool(value)


@pytest.mark.parametrize("value", ["no", "", 0, 1, None, np.array([True]), [True]])
def test_as_flag_refuses_everything_else(value):
    with pytest.raises(ModelError, match=r"^project: expected True or False"):
        as_flag(value, "project")


def test_as_instance_names_the_expected_class():
    assert as_instance(3, "n", int) == 3
    with pytest.raises(ModelError, match=r"^bank: expected an instance of int or float, got 'x' of type str"):
        as_instance("x", "bank", (int, float))
    with pytest.raises(ModelError, match=r"^bank: expected a ResidualBank, got None"):
        as_instance(None, "bank", int, "a ResidualBank")
