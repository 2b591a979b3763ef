"""Layout of the moving-horizon package: the tier rule (mhe below observers), the typed window
result and the one backend signature."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

from hybobs_opt.cli._common import json_default
from hybobs_opt.mhe import MHEObserver, MHESettings, UniquenessOutcome, WindowResult
from hybobs_opt.mhe.backends import Backend, BackendOutcome
from hybobs_opt.results import SolveResult
from hybobs_opt.status import Status
from hybobs_opt.studies.registry import get_example

MHE_DIR = Path(__file__).resolve().parents[3] / "hybobs_opt" / "mhe"


@pytest.fixture(scope="module")
def window():
    ex = get_example("powertrain3")
    plant = ex.build()
    tr = ex.scenario(plant)
    k = 995
    return plant, tr, k


def test_mhe_never_imports_the_observers_package():
    """DESIGN.md draws mhe -> observers (arrows point down): mhe uses the contract module."""
    offenders = []
    for path in MHE_DIR.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                mod = ("." * node.level) + (node.module or "")
                if "observers" in mod:
                    offenders.append(f"{path.name}: from {mod}")
            elif isinstance(node, ast.Import):
                offenders += [f"{path.name}: import {a.name}" for a in node.names if "observers" in a.name]
    assert not offenders


@pytest.mark.parametrize("norm", ["2", "1"])
def test_window_result_is_typed_and_reads_like_the_old_dict(window, norm):
    plant, tr, k = window
    obs = MHEObserver(plant, 3, norm=norm, settings=MHESettings(zero_cost_certificate=False))
    out = obs.solve_window(tr.u[k:k + 3], tr.y[k:k + 3], x_start=tr.x[k] * 1.01, uniqueness=True)
    assert isinstance(out, WindowResult) and isinstance(out, SolveResult)
    assert out.status is Status.OPTIMAL and out["status"] == "optimal" and out.optimal
    assert out.seconds > 0 and np.isfinite(out.seconds)
    assert 0.0 <= out.residuals["mld_rows"] <= 1e-7
    d = out.to_dict()
    assert {"status", "solver", "solved_by", "polished", "x_start", "states", "modes", "w", "cost", "gap_bound",
            "passes", "uniqueness"} <= set(d)
    assert "seconds" not in d and "residuals" not in d  # the old keys, exactly
    assert "reason" not in out and out.get("reason") is None and out.get("alternative", 7) == 7
    assert dict(out) == d and out["uniqueness"]["status"] == "unique"
    assert out["uniqueness"]["status"] is UniquenessOutcome.UNIQUE
    assert json.dumps(str(out.status)) == '"optimal"'
    with pytest.raises(KeyError):
        out["no such key"]
    with pytest.raises(TypeError):
        out.replace(no_such_field=1)


def test_uniqueness_outcomes_are_the_strings_of_the_json():
    """The enum's values are the strings ``info["uniqueness"]["status"]`` has always held: a dict
    with a member serialises to the same text as with the plain string, with the CLI's encoder too."""
    assert {o.value for o in UniquenessOutcome} == {"unique", "alternative", "not certified",
                                                     "not unique for every input"}
    for outcome in UniquenessOutcome:
        info = {"uniqueness": {"status": outcome, "decided_by": "x", "threshold": np.float64(1.5)}}
        plain = {"uniqueness": {"status": outcome.value, "decided_by": "x", "threshold": 1.5}}
        assert json.dumps(info, default=json_default) == json.dumps(plain)
        assert str(outcome) == f"{outcome}" == outcome.value and outcome == outcome.value
        assert json.loads(json.dumps(outcome)) == outcome.value


def test_not_certified_window_keeps_the_old_keys(window):
    plant, tr, k = window
    # a limited branch and bound, and a prefix search allowed one node QP: nothing certifies the window
    obs = MHEObserver(plant, 3, settings=MHESettings(solver_options={"iter_limit": 1}, zero_cost_certificate=False,
                                                     certify_max_nodes=1))
    out = obs.solve_window(tr.u[k:k + 3], tr.y[k:k + 3], x_start=tr.x[k])
    assert out.status == Status.NOT_CERTIFIED and "reason" in out and out.residuals == {}
    assert out["solver"] == "daqp" and "solver_status" in out


def test_backends_have_one_signature(window):
    plant, _, _ = window
    for norm in ("2", "1"):
        obs = MHEObserver(plant, 3, norm=norm)
        for backend in (obs._backend, obs._u_miqp, obs._u_milp):
            if backend is None:
                continue
            assert isinstance(backend, Backend)
            assert isinstance(backend.cutoff_applied, bool) and backend.abs_subopt >= 0


def test_backend_outcome_maps_raw_statuses():
    out = BackendOutcome("not certified", None, {"status": -4}, Status.LIMIT)
    assert out.status is Status.NOT_CERTIFIED and out.solver_status is Status.LIMIT
    assert out.to_dict()["solver_status"] == "limit"


def test_reset_takes_the_initial_mode_as_q0(window):
    from hybobs_opt.errors import ModelError

    plant, tr, k = window
    obs = MHEObserver(plant, 3, x0=tr.x[k])
    obs.reset(tr.x[k], q0=1)
    assert obs.step(tr.u[k], tr.y[k]).mode == 1
    with pytest.raises(ModelError) as err:
        obs.reset(tr.x[k], q0=plant.n_modes)
    assert err.value.field == "q0"
