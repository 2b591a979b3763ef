"""The package's loggers, ``verbose_logging`` and the ``verbose=`` keyword of the solver-facing entry points."""

from __future__ import annotations

import inspect
import io
import logging

import cvxpy as cp
import numpy as np
import pytest

import hybobs_opt
from hybobs_opt import MHEObserver, ModelError, analyse_observability, load_model
from hybobs_opt._logging import LOGGER_NAME, verbose_level, verbose_logging
from hybobs_opt.lmi.solve import solve_problem
from hybobs_opt.sim import simulate_pwa

ROT = "examples/models/bemporad_morari_rotation.json"


@pytest.fixture(scope="module")
def rotation():
    from pathlib import Path

    return load_model(Path(__file__).resolve().parents[3] / ROT)


def test_the_package_logger_has_a_null_handler_and_no_level():
    logger = logging.getLogger(LOGGER_NAME)
    assert LOGGER_NAME == hybobs_opt.__name__
    assert any(isinstance(h, logging.NullHandler) for h in logger.handlers)
    assert logger.level == logging.NOTSET and logger.propagate


def _small_lmi() -> cp.Problem:
    P = cp.Variable((2, 2), symmetric=True)
    A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    return cp.Problem(cp.Minimize(cp.trace(P)), [P >> np.eye(2), A.T @ P + P @ A << -np.eye(2)])


def test_caplog_sees_each_lmi_solve(caplog):
    with caplog.at_level(logging.DEBUG, logger=LOGGER_NAME):
        out = solve_problem(_small_lmi())
    records = [r for r in caplog.records if r.name == "hybobs_opt.lmi.solve"]
    assert len(records) == 1
    msg = records[0].getMessage()
    assert records[0].levelno == logging.DEBUG
    assert "4 variable entries, 2 constraints (2 PSD)" in msg  # the 2x2 matrix P
    assert f"solver CLARABEL, status {out.status}" in msg and str(out.status) == "optimal"
    assert f"{out.seconds:.3g} s" in msg


def test_no_record_is_formatted_at_the_default_level(caplog):
    caplog.set_level(logging.WARNING)
    solve_problem(_small_lmi())
    assert not [r for r in caplog.records if r.name.startswith(LOGGER_NAME)]


def test_verbose_level():
    assert verbose_level(True) == logging.INFO
    assert verbose_level(False) is None and verbose_level(None) is None and verbose_level(0) is None
    assert verbose_level(logging.DEBUG) == 10
    for bad in (-1, "info", 1.5):
        with pytest.raises(ModelError) as err:
            verbose_level(bad)
        assert err.value.field == "verbose"


def test_verbose_logging_writes_to_stderr_and_restores_the_logger(capsys):
    logger = logging.getLogger(LOGGER_NAME)
    handlers, level = list(logger.handlers), logger.level
    with verbose_logging(True):
        with verbose_logging(logging.DEBUG):  # nested: no second handler, no line twice
            logging.getLogger("hybobs_opt.test").info("phase one")
        logging.getLogger("hybobs_opt.test").debug("hidden at INFO")
        logging.getLogger("other.package").info("not ours")
    out, err = capsys.readouterr()
    assert out == ""
    assert err == "hybobs INFO hybobs_opt.test: phase one\n"
    assert logger.handlers == handlers and logger.level == level


def test_verbose_logging_off_writes_nothing():
    buf = io.StringIO()
    with verbose_logging(False, stream=buf):
        logging.getLogger("hybobs_opt.test").warning("no handler of ours")
    assert buf.getvalue() == ""


@pytest.mark.parametrize("entry", ["analyse_observability", "diagnose", "synthesize_switched", "design_switched"])
def test_entry_points_take_verbose(entry):
    fn = getattr(hybobs_opt, entry)
    param = inspect.signature(fn).parameters["verbose"]
    assert param.kind is inspect.Parameter.KEYWORD_ONLY and param.default is False
    assert "verbose : bool or int" in fn.__doc__
    assert "verbose" in inspect.signature(MHEObserver).parameters


def test_analyse_observability_verbose_logs_its_phases(rotation, capsys):
    analysis = analyse_observability(rotation, 2, verbose=True)
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 2, err
    assert lines[0].startswith("hybobs INFO hybobs_opt.regions.observability: Algorithm 3.1 of paper 002 at T = 2: "
                               f"mode enumeration gave {len(analysis.enumeration.regions)} regions")
    assert f"with {analysis.n_pair_lps} LPs" in lines[1]
    analyse_observability(rotation, 2)
    assert capsys.readouterr().err == ""


def test_mhe_observer_verbose_logs_windows_and_the_run(rotation, capsys):
    U = 0.5 * np.sin(np.arange(8))[:, None]
    trace = simulate_pwa(rotation, np.array([3.0, -2.0]), U)
    obs = MHEObserver(rotation, 3, verbose=logging.DEBUG)
    run = obs.run(trace.u, trace.y)
    err = capsys.readouterr().err
    windows = [ln for ln in err.splitlines() if "MHE window" in ln]
    assert len(windows) == 8 - 2  # one per sample once the window is full
    assert all("solver daqp, status" in ln for ln in windows)
    assert f"MHE run (T = 3, norm 2, solver daqp): 8 samples" in err
    assert run.n_steps == 8
    quiet = MHEObserver(rotation, 3)
    quiet.run(trace.u, trace.y)
    assert capsys.readouterr().err == ""
    with pytest.raises(ModelError):
        MHEObserver(rotation, 3, verbose="yes")
