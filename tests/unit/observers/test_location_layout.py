"""Layout of the location observer (LMI design / identification logic / runtime object), the
certificate base class of DelayCertificate and the LMI status policy."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybobs_opt.errors import SolverError
from hybobs_opt.observers import location_logic
from hybobs_opt.synthesis import location_design
from hybobs_opt.observers import location_observer as lo
from hybobs_opt.results import Certificate
from hybobs_opt.status import Status

def test_the_runtime_module_serves_no_old_private_name():
    """One path per name: the design's helpers are imported from the design module."""
    for name in ("_affine_key", "_sqrt_psd", "_search_decay", "expm", "solve_problem"):
        assert not hasattr(lo, name), name
    assert lo.LocationLogic is location_logic.LocationLogic


def test_delay_certificate_implements_the_certificate_protocol():
    cert = location_design.DelayCertificate("q1", np.array([[0.0, 1.0], [-1.0, 0.0]]), np.array([[1.0, 0.0]]),
                                            delta=0.1, epsilon=0.01, z0_bound=1.0, gain_bound=0.1)
    assert isinstance(cert, Certificate)
    assert cert.verify() is True and "q1" in cert.reason and "eq. 13" in cert.reason
    loose = dataclasses.replace(cert, epsilon=10.0)
    assert loose.verify() is False


def test_inaccurate_lmi_optimum_is_refused(monkeypatch):
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    C = np.array([[1.0, 0.0]])
    lmi = location_design.LuenbergerLMI(2, 1)
    P, L, status, _ = lmi.solve(A, C, 1.0, "test LMI")
    assert status == "optimal" and np.all(np.linalg.eigvalsh(P) > 0)
    real = location_design.solve_problem

    def inaccurate(problem):
        return dataclasses.replace(real(problem), status=Status.OPTIMAL_INACCURATE)

    monkeypatch.setattr(location_design, "solve_problem", inaccurate)
    with pytest.raises(SolverError, match="optimal_inaccurate"):
        lmi.solve(A, C, 1.0, "test LMI")
