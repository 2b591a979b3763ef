"""The ``executor`` argument of the analyses (issue 16: ``executor="serial"`` was an AttributeError)."""

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.executor import SerialExecutor
from hybobs_opt.regions.enumeration import enumerate_modes
from hybobs_opt.regions.observability import analyse_observability
from hybobs_opt.studies.paper002_powertrain.systems import powertrain3


def test_executor_by_name_gives_the_serial_answer():
    system = powertrain3()
    by_object = analyse_observability(system, 3, executor=SerialExecutor())
    by_name = analyse_observability(system, 3, executor="serial")
    assert len(by_name.enumeration.regions) == len(by_object.enumeration.regions) > 0
    assert [r.sequence for r in by_name.enumeration.regions] == [r.sequence for r in by_object.enumeration.regions]
    assert len(enumerate_modes(system, 3, executor="serial").regions) == len(by_object.enumeration.regions)


@pytest.mark.parametrize("bad", ["threads", 3, object()])
def test_a_bad_executor_is_a_model_error_naming_it(bad):
    with pytest.raises(ModelError, match="executor"):
        analyse_observability(powertrain3(), 3, executor=bad)
