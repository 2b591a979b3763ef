"""Every notebook in notebooks/ runs top to bottom and draws (DESIGN.md: notebooks are part of the tests).

The slow test executes each notebook with nbclient (in a temporary folder) and asserts no error
output and at least one ``image/png`` output.  The fast tests read the stored notebooks: they open
with a markdown cell, leave the matplotlib backend to Jupyter (no ``matplotlib.use``), and carry
their executed outputs (at least one figure, no error), so they read on GitHub without running.
"""

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "notebooks").glob("*.ipynb"))
IDS = [p.name for p in NOTEBOOKS]
BACKEND_FORCING = re.compile(r"\b(matplotlib|mpl)\s*\.\s*use\s*\(|\bplt\s*\.\s*switch_backend\s*\(|MPLBACKEND")


def code_outputs(nb):
    return [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]


def error_outputs(nb):
    return [f"{o.get('ename')}: {o.get('evalue')}" for o in code_outputs(nb) if o.get("output_type") == "error"]


def png_outputs(nb):
    return [o for o in code_outputs(nb) if "image/png" in o.get("data", {})]


@pytest.mark.notebook
@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=IDS)
def test_notebook_runs(path, tmp_path):
    nb = nbformat.read(path, as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    assert not error_outputs(nb)
    assert png_outputs(nb), f"{path.name} produced no image/png output"


def test_the_notebooks_are_found():
    assert len(NOTEBOOKS) >= 8


@pytest.mark.parametrize("path", NOTEBOOKS, ids=IDS)
def test_stored_notebook(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    assert nb.cells and nb.cells[0].cell_type == "markdown" and nb.cells[0].source.lstrip().startswith("#"), \
        f"{path.name} must open with a markdown cell saying what it shows"
    forcing = [c.source for c in nb.cells if c.cell_type == "code" and BACKEND_FORCING.search(c.source)]
    assert not forcing, f"{path.name} forces a matplotlib backend (use %matplotlib inline): {forcing}"
    assert not error_outputs(nb), f"{path.name} is stored with error outputs"
    assert png_outputs(nb), f"{path.name} is stored without its executed figures (run it and save the outputs)"
    unexecuted = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and c.source.strip() and c.execution_count is None]
    assert not unexecuted, f"{path.name}: code cells {unexecuted} are stored unexecuted"
