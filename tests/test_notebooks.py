"""The worked notebooks run top to bottom, and are committed without outputs.

Each notebook in ``notebooks/`` is executed with nbclient in a fresh kernel, with the
notebooks directory as working directory (as a user opening it in Jupyter has); any cell
error (including the notebooks' own ``assert`` checks against closed forms and printed
reference values) fails the test. The timeout is per cell and only guards against a hung
kernel. See notebooks/README.md for the output-stripped convention.
"""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="the test extra (nbformat) is not installed")
nbclient = pytest.importorskip("nbclient", reason="the test extra (nbclient) is not installed")
pytest.importorskip("ipykernel", reason="the test extra (ipykernel) is not installed")
pytest.importorskip("matplotlib", reason="the plot extra (matplotlib) is not installed")

NOTEBOOKS_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOKS_DIR.glob("*.ipynb"))
CELL_TIMEOUT = 600  # seconds per cell: a hang guard, far above the few seconds a cell takes


def test_notebooks_exist():
    names = {p.name for p in NOTEBOOKS}
    for required in ("01_thesis_crank_rocker.ipynb", "02_example1_slider_crank.ipynb",
                     "03_notes_problems.ipynb", "04_quick_return_coriolis.ipynb"):
        assert required in names
    assert (NOTEBOOKS_DIR / "README.md").is_file()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_committed_notebook_is_clean(path):
    """Committed notebooks carry no outputs or execution counts (see notebooks/README.md)."""
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    dirty = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and (c.outputs or c.execution_count)]
    assert not dirty, f"{path.name}: cells {dirty} have outputs; strip them (notebooks/README.md)"
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")
    assert nb.metadata.kernelspec.name == "python3"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path):
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=CELL_TIMEOUT, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOKS_DIR)}})
    client.execute()  # raises CellExecutionError naming the cell and the traceback
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs
              if "image/png" in o.get("data", {}) or "image/gif" in o.get("data", {})]
    assert images, f"{path.name} shows no picture"
