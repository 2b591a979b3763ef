"""The package's metadata agree with each other and with what an install from PyPI needs.

* one version: ``pyproject.toml``, ``hybobs_opt.__version__`` and ``CITATION.cff``;
* every runtime dependency and every extra has an upper bound (an unpinned install must not pick
  up a major release the suite never ran: a 0.x package's next minor counts as major);
* the sdist carries the changelog and the citation file, and the project names its authors and
  valid-looking trove classifiers.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

import hybobs_opt

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
PROJECT = PYPROJECT["project"]

_REQUIREMENT = re.compile(r"^(?P<name>[A-Za-z0-9_.-]+)(?:\[[^\]]*\])?(?P<spec>.*)$")


def _requirements() -> list[str]:
    out = list(PROJECT["dependencies"])
    for extra, items in PROJECT["optional-dependencies"].items():
        out += [item for item in items if not item.startswith("hybobs_opt[")]
    return out


def test_one_version_everywhere():
    citation = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    cff_version = re.search(r"^version:\s*\"?([^\"\n]+)\"?\s*$", citation, flags=re.MULTILINE).group(1)
    assert PROJECT["version"] == hybobs_opt.__version__ == cff_version


@pytest.mark.parametrize("requirement", _requirements())
def test_every_dependency_has_an_upper_bound(requirement):
    m = _REQUIREMENT.match(requirement.replace(" ", ""))
    assert m, requirement
    specs = m.group("spec").split(",")
    uppers = [s for s in specs if s.startswith("<") or s.startswith("==") or s.startswith("~=")]
    assert uppers, f"{requirement!r}: no upper bound (add '<NEXT_MAJOR')"
    lowers = [s for s in specs if s.startswith(">=")]
    assert lowers, f"{requirement!r}: no lower bound"


def test_upper_bounds_admit_the_pinned_versions():
    """constraints.txt (what the suite runs) satisfies every bound of pyproject.toml."""
    from packaging.requirements import Requirement

    pins = {}
    for line in (ROOT / "constraints.txt").read_text(encoding="utf-8").splitlines():
        if "==" in line and not line.startswith("#"):
            name, version = line.split("==", 1)
            pins[name.strip().lower().replace("_", "-")] = version.strip()
    checked = 0
    for text in _requirements():
        req = Requirement(text)
        version = pins.get(req.name.lower().replace("_", "-"))
        if version is not None:
            assert req.specifier.contains(version, prereleases=True), f"{text}: the pinned {version} is outside"
            checked += 1
    assert checked >= 10


def test_metadata_names_authors_and_classifiers():
    assert PROJECT["authors"] and all(a.get("name") for a in PROJECT["authors"])
    classifiers = PROJECT["classifiers"]
    assert any(c.startswith("Development Status ::") for c in classifiers)
    assert "Programming Language :: Python :: 3.11" in classifiers
    assert all(re.fullmatch(r"[A-Za-z0-9 /().+-]+( :: [A-Za-z0-9 /().+-]+)+", c) for c in classifiers), classifiers


def test_sdist_carries_changelog_and_citation():
    manifest = (ROOT / "MANIFEST.in").read_text(encoding="utf-8")
    include = " ".join(line for line in manifest.splitlines() if line.startswith("include "))
    for name in ("CHANGELOG.md", "CITATION.cff", "LICENSE", "README.md", "constraints.txt"):
        assert (ROOT / name).is_file(), name
        assert name in include.split(), f"MANIFEST.in does not include {name}"
