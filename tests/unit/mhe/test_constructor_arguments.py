"""MHEObserver's weights are validated, nothing coerced (issue 16: ``prox_weight=True`` was read as
1, a negative diagonal output weight and a complex weight were accepted)."""

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.mhe import MHEObserver, MHESettings
from hybobs_opt.studies.registry import get_example


@pytest.fixture(scope="module")
def plant():
    return get_example("powertrain3").build()


@pytest.mark.parametrize("kw, field", [
    (dict(output_weight=[-1.0]), "output_weight"), (dict(output_weight=1j), "output_weight"),
    (dict(output_weight="2"), "output_weight"), (dict(output_weight=[True]), "output_weight"),
    (dict(disturbance_weight=[1.0, -1.0, 1.0]), "disturbance_weight"), (dict(output_weight=[[-1.0]]), "output_weight"),
])
def test_a_bad_weight_is_a_model_error_naming_it(plant, kw, field):
    with pytest.raises(ModelError) as err:
        MHEObserver(plant, 3, **kw)
    assert err.value.field == field


def test_valid_weights_are_accepted(plant):
    obs = MHEObserver(plant, 3, output_weight=100, settings=MHESettings(prox_weight=1, binary_prox_weight=2.5),
                      disturbance_weight=[1e4, 1e2, 1e3])
    assert obs.settings.prox_weight == 1.0 and obs.settings.binary_prox_weight == 2.5
