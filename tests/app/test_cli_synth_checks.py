"""``hybobs synth``: the dwell-time error and ``--accept-unenforced-dwell``, the ``verification``
field and ``--no-verify`` (paper 004's switched gains).

The piston case: its preset with the design rate at 0.5 x the largest (monkeypatched in the
preset table) gives tau ~ 0.028 s, while the 1 mm hysteresis at 160 mm/s guarantees only
2 x 1 / 160 = 0.0125 s (computed here).  The vehicle's frozen error dynamics are recomputed here
from the gains in the JSON (numpy, eq. 59's derivatives written by hand).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from hybobs_opt.cli import main
from hybobs_opt.studies.paper004_nonmonotonic import presets

V = 10.0
K_TAN = V / (1.1 + 1.58)
DELTA_MAX = math.radians(10.0)
F = np.vstack([np.eye(3), np.zeros((1, 3))])
E = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


@pytest.fixture
def piston_at_half(monkeypatch):
    monkeypatch.setitem(presets.PRESETS, "magnetic_piston",
                        dataclasses.replace(presets.PRESETS["magnetic_piston"], decay_fraction=0.5))


def test_unenforced_dwell_is_an_error_naming_the_flag(capsys, tmp_path, piston_at_half):
    path = tmp_path / "gains.json"
    code, out, err = run(capsys, "synth", "magnetic_piston", "--out", path)
    assert code == 2
    assert "--accept-unenforced-dwell" in err and "does not enforce the dwell time" in err
    assert not path.exists()


def test_unenforced_dwell_accepted_with_the_flag(capsys, tmp_path, piston_at_half):
    path = tmp_path / "gains.json"
    out = run_json(capsys, "synth", "magnetic_piston", "--out", path, "--accept-unenforced-dwell", "--no-verify")
    guarantee = 2 * 1.0 / 160.0  # 2 eps / max rate (mm, mm/s)
    intervals = [r["interval_model"] for r in out["regions"]]
    for lo, hi in intervals[1:-1]:
        guarantee = min(guarantee, (hi - lo - 2 * 1.0) / 160.0)
    assert guarantee < out["tau"], (guarantee, out["tau"])
    assert out["dwell_enforced"] is False and out["accepted_unenforced_dwell"] is True
    assert len(out["warnings"]) == 1 and "dwell" in out["warnings"][0]
    assert out["verification"] is None
    assert json.loads(path.read_text())["warnings"] == out["warnings"]


def _frozen_max_eig(L, lo, hi):
    psi, delta = np.meshgrid(np.linspace(lo, hi, 257), np.linspace(-DELTA_MAX, DELTA_MAX, 41), indexing="ij")
    S = np.stack([-V * np.sin(psi.ravel()), V * np.cos(psi.ravel()), K_TAN / np.cos(delta.ravel()) ** 2], axis=-1)
    J = np.einsum("ij,kj,jl->kil", F, S, E) - (np.asarray(L) @ C)[None]
    return float(np.linalg.eigvals(J).real.max())


def test_vehicle_synth_json_has_a_passing_verification(capsys, tmp_path):
    out = run_json(capsys, "synth", "vehicle_tracking", "--out", tmp_path / "gains.json")
    v = out["verification"]
    assert v["ok"] is True
    times = v["simulation"]["convergence_times"]
    assert len(times) >= 1 and all(t is not None and math.isfinite(t) for t in times)
    assert all(t < v["simulation"]["t_final"] for t in times)
    assert len(v["frozen"]) == len(out["regions"])
    for f, r in zip(v["frozen"], out["regions"]):
        mine = _frozen_max_eig(r["L"], *r["interval_model"])
        assert f["max_real_eig"] <= mine + 1e-9 and f["max_real_eig"] < 0 and mine < 0
        assert mine <= -0.5 * r["sigma"] and f["ok"] is True
    assert out["solver_counts"]["undecided"] == 0


def test_vehicle_synth_no_verify_gives_null(capsys, tmp_path):
    out = run_json(capsys, "synth", "vehicle_tracking", "--out", tmp_path / "gains.json", "--no-verify")
    assert "verification" in out and out["verification"] is None
    assert json.loads((tmp_path / "gains.json").read_text())["verification"] is None
