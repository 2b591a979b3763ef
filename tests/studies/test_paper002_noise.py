"""The noise study of paper 002 (issue 18): what its table must show, on a shortened scenario.

The true states of the simulation are the oracle: the paper's lookup observer flags estimates
observable whose errors are far beyond the noise-aware observer's stated covariance (the defect
the study exists to show), the noise-aware lookup never does, and the Kalman filter told the true
modes (the unattainable reference) is the most accurate on the samples it flags.
"""

from __future__ import annotations

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.studies.paper002_powertrain.noise import run_noise_study


@pytest.fixture(scope="module")
def table():
    return run_noise_study("powertrain3", (0.01,), 1500, observers=("lookup", "lookup-noise", "kalman"),
                           lookup_horizons=(4,))


def test_noise_aware_lookup_flags_no_estimate_beyond_five_sigma(table):
    rec = table["levels"][0]["observers"]["lookup-noise"]
    assert rec["flags"]["observable"] > 100
    assert rec["n_flagged_beyond_5_sigma"] == 0
    assert rec["max_mahalanobis_flagged"] < 5.0


def test_paper_lookup_passes_the_noise_into_flagged_estimates(table):
    """With T p = n the paper's observer calls noisy windows observable: omega_l errors of several
    rad/s (26 rad/s on the full scenario), while the noise-aware one's flagged errors stay within
    its covariance and the Kalman filter's are smaller still."""
    obs = table["levels"][0]["observers"]
    paper = obs["lookup"]["max_abs_error_flagged_observable"]["omega_l"]
    assert paper > 5.0
    kf = obs["kalman"]["rms_error_flagged_observable"]["omega_l"]
    noisy = obs["lookup-noise"]["rms_error_flagged_observable"]["omega_l"]
    assert kf < noisy < obs["lookup"]["rms_error_flagged_observable"]["omega_l"]


def test_bad_arguments_name_the_field():
    with pytest.raises(ModelError, match="observers"):
        run_noise_study("powertrain3", (0.01,), 100, observers=("kalman", "ekf"))
    with pytest.raises(ModelError, match="noise_levels"):
        run_noise_study("powertrain3", (0.0,), 100)
