"""Fixtures of the MHE tests."""

import pytest

from hybobs_opt.studies.registry import get_example


@pytest.fixture(scope="module")
def plant_trace():
    """The powertrain3 plant (model (16) of paper 002) and its scenario."""
    ex = get_example("powertrain3")
    plant = ex.build()
    return plant, ex.scenario(plant)
