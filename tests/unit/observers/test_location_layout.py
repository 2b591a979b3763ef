"""Layout of the location observer after the split of issue 13 (LMI design / identification logic /
runtime object), the certificate protocol of DelayCertificate and the LMI status policy."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybobs_opt.errors import SolverError
from hybobs_opt.observers import location_design, location_logic
from hybobs_opt.observers import location_observer as lo
from hybobs_opt.results import Certificate
from hybobs_opt.status import Status

#: Every module-level name of hybobs_opt/observers/location_observer.py before the split.
OLD_NAMES = [
    "math", "time", "Sequence", "dataclass", "Any", "np", "expm", "InfeasibleError", "ModelError", "SolverError",
    "HybridAutomaton", "DELAY_DESIGN_RTOL", "LOCATION_INVARIANT_RTOL", "LUENBERGER_LMI_MARGIN", "MATRIX_EQUAL_RTOL",
    "OBSERVABILITY_RTOL", "SOLVER", "SOLVER_ERROR", "solve_problem", "FALLBACK", "OBSERVABLE", "UNOBSERVABLE",
    "WARMING_UP", "Estimate", "Observer", "ObserverTrace", "initial_state", "DECAY_GUARD", "MAX_DECAY_ITERATIONS",
    "IDENTIFIED", "AMBIGUOUS", "NO_CANDIDATE", "location_label", "_affine_key", "_same", "distinct_dynamics",
    "state_scale", "check_observable", "jordan_kappa", "spectral_abscissa", "_sqrt_psd", "certified_decay",
    "sampled_observer", "LuenbergerLMI", "ResidualGenerator", "ResidualBank", "DelayCertificate",
    "design_residual_bank", "_search_decay", "_generator", "_invariant_margins", "prop_3_1_3_matrix",
    "LocationDecision", "LocationLogic", "LocationRun", "LocationObserver", "_as_samples", "_block_diag",
    "detection_delays",
]


def test_every_old_name_is_still_importable():
    assert [n for n in OLD_NAMES if not hasattr(lo, n)] == []
    assert lo.LuenbergerLMI is location_design.LuenbergerLMI
    assert lo.LocationLogic is location_logic.LocationLogic
    assert lo._affine_key is location_design.affine_key and lo._sqrt_psd is location_design.sqrt_psd


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
