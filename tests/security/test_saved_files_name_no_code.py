"""A saved file never names code: a regions file without its model rebuilds its system from a
registered example only.

The campaign's attack: a version-2 regions file with no ``system_model`` and ``"example":
"subprocess:run"``, ``"params": {"args": ..., "shell": true}``, its checksum recomputed (a plain
SHA-256 anyone can recompute): ``load_analysis`` ran the shell command.  Oracle: a marker file the
command would create, and the modules imported.
"""

from __future__ import annotations

import json
import sys

import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.regions import analyse_observability, load_analysis, save_analysis
from hybobs_opt.studies import get_example
from hybobs_opt.systems.saved_file import content_checksum


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    path = tmp_path_factory.mktemp("regions") / "p3.json"
    save_analysis(analyse_observability(get_example("powertrain3").build(), 3), path, "powertrain3", {})
    return json.loads(path.read_text())


def _without_model(data: dict, example, params) -> dict:
    out = {k: v for k, v in data.items() if k not in ("system_model", "checksum")}
    out.update(example=example, params=params)
    return dict(out, checksum=content_checksum(out))


@pytest.mark.parametrize("example, params", [
    ("subprocess:run", {"args": "touch MARKER", "shell": True}),
    ("os:system", {"command": "touch MARKER"}),
    ("hybobs_user_evil.py:build", {}),
    ("/tmp/evil.py:build", {}),
    ("../models/evil.toml", {}),
    ("json:loads", {"s": "{}"}),
], ids=["subprocess", "os.system", "py-file", "abs-py-file", "model-path", "harmless-module"])
def test_no_module_or_file_named_in_a_saved_file_is_imported_or_run(saved, tmp_path, monkeypatch, example, params):
    monkeypatch.chdir(tmp_path)
    for p in params.values():
        if isinstance(p, str):
            params = {k: (v.replace("MARKER", str(tmp_path / "MARKER")) if isinstance(v, str) else v)
                      for k, v in params.items()}
    path = tmp_path / "evil.json"
    path.write_text(json.dumps(_without_model(saved, example, params)))
    before = set(sys.modules)
    with pytest.raises(ModelError, match="never names code"):
        load_analysis(path)
    assert not (tmp_path / "MARKER").exists()
    assert not any(m.startswith("hybobs_user_") for m in set(sys.modules) - before)


def test_a_registered_example_still_rebuilds_the_system(saved, tmp_path):
    path = tmp_path / "ok.json"
    path.write_text(json.dumps(_without_model(saved, "powertrain3", {})))
    analysis = load_analysis(path)
    assert analysis.T == 3 and analysis.system.name.startswith("powertrain3")
