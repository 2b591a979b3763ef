"""Example catalogues through the entry point group (:mod:`hybobs_opt.systems.catalogue`).

The core never imports the studies: ``import hybobs_opt`` loads none of them, changes no
environment variable and starts no thread or process; the seed papers' examples are still found
by name (``hybobs_opt.get_example``, a saved file's example name) through the installed entry
point.  Each import check runs in a fresh interpreter.
"""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

import pytest

from hybobs_opt.errors import ModelError

UPPER = ("hybobs_opt.studies", "hybobs_opt.cli", "hybobs_opt.report")


def _fresh(code: str) -> dict:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_importing_the_package_loads_no_study_and_changes_nothing():
    rec = _fresh(
        "import json, os, sys, threading\n"
        "before = dict(os.environ)\n"
        "import hybobs_opt, hybobs_opt.geometry, hybobs_opt.systems, hybobs_opt.regions\n"
        "print(json.dumps({'mods': sorted(m for m in sys.modules if m.startswith('hybobs_opt')),\n"
        "                  'env_same': before == dict(os.environ), 'threads': threading.active_count(),\n"
        "                  'children': len(__import__('multiprocessing').active_children())}))\n")
    upper = [m for m in rec["mods"] if m.startswith(UPPER)]
    assert upper == [] and rec["env_same"] and rec["threads"] == 1 and rec["children"] == 0, rec


def test_importtime_of_the_geometry_names_no_upper_tier_module():
    out = subprocess.run([sys.executable, "-X", "importtime", "-c", "import hybobs_opt.geometry"], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    loaded = [line.rsplit("|", 1)[-1].strip() for line in out.stderr.splitlines() if line.startswith("import time:")]
    assert "hybobs_opt.geometry" in loaded
    assert [m for m in loaded if m.startswith(UPPER)] == []


def test_examples_are_found_through_the_entry_point_in_a_fresh_process():
    """The root's ``get_example`` and a saved file's name (``resolve_registered``) reach the seed
    papers' examples without anything importing the studies first."""
    rec = _fresh(
        "import json, sys\n"
        "import hybobs_opt\n"
        "from hybobs_opt.systems.resolve import resolve_registered\n"
        "plant = resolve_registered('powertrain3', {'gear_ratio': 0.1})\n"
        "ex = hybobs_opt.get_example('vehicle_tracking')\n"
        "print(json.dumps({'plant': type(plant).__name__, 'example': ex.name, 'paper': ex.paper,\n"
        "                  'n': len(hybobs_opt.list_examples())}))\n")
    assert rec == {"plant": "PWASystem", "example": "vehicle_tracking", "paper": "004", "n": 10}


def test_the_catalogue_lists_what_the_studies_register():
    from hybobs_opt import get_example, list_examples
    from hybobs_opt.studies import list_examples as studies_list

    assert [ex.name for ex in list_examples()] == [ex.name for ex in studies_list()]
    assert get_example("powertrain3") is studies_list()[[e.name for e in studies_list()].index("powertrain3")]
    with pytest.raises(ModelError, match="powertrain3"):  # the message lists the names there are
        get_example("nosuch")


def test_a_catalogue_without_its_functions_is_refused(monkeypatch):
    import importlib.metadata

    from hybobs_opt.systems import catalogue

    broken = SimpleNamespace(name="broken", value="somewhere:thing", load=lambda: SimpleNamespace(list_examples=list))
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: [broken] if group == catalogue.ENTRY_POINT_GROUP else [])
    monkeypatch.setattr(catalogue, "_LOADED", None)
    with pytest.raises(ModelError, match="get_example, list_examples and resolve_example"):
        catalogue.list_examples()
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: [])
    monkeypatch.setattr(catalogue, "_LOADED", None)
    with pytest.raises(ModelError, match="no entry point"):
        catalogue.get_example("powertrain3")
