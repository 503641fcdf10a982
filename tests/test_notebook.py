"""The tutorial notebook (docs/tutorial.ipynb) is committed without outputs and runs top to bottom."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import nbclient
import nbformat
import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"
#: figures the tutorial draws: shape, model overlay, reach samples, tip scatter, GA convergence, optimum
FIGURES = 6


def code_cells(nb):
    return [c for c in nb.cells if c.cell_type == "code"]


def tagged(nb, tag: str):
    cells = [c for c in code_cells(nb) if tag in c.metadata.get("tags", [])]
    assert len(cells) == 1, f"expected one cell tagged {tag!r}, found {len(cells)}"
    return cells[0]


def stdout(cell) -> str:
    return "".join(o.text for o in cell.outputs if o.output_type == "stream" and o.name == "stdout")


def test_the_committed_notebook_has_no_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    assert nb.metadata.kernelspec.name == "python3"
    for k, cell in enumerate(code_cells(nb)):
        assert cell.outputs == [], f"code cell {k} has outputs: strip them before committing"
        assert cell.execution_count is None, f"code cell {k} has an execution count: strip it before committing"


@pytest.mark.slow
def test_the_notebook_runs(tmp_path, monkeypatch):
    # headless: figures as inline PNGs whatever backend the caller chose (make test sets Agg)
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    # the kernel must be this interpreter (jupyter_client runs a kernelspec's "python" as sys.executable)
    probe = nbformat.v4.new_code_cell("import sys\nprint(sys.executable)\nprint(sys.prefix)")
    nb.cells.insert(0, probe)
    copy = tmp_path / "tutorial.ipynb"
    nbformat.write(nb, copy)
    nb = nbformat.read(copy, as_version=4)

    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()

    assert stdout(code_cells(nb)[0]).split() == [sys.executable, sys.prefix]
    for k, cell in enumerate(code_cells(nb)):  # nbclient raises on the first error; this says it twice
        errors = [o for o in cell.outputs if o.output_type == "error"]
        assert not errors, f"code cell {k} failed: {errors}"
    images = sum("image/png" in o.get("data", {}) for c in code_cells(nb) for o in c.outputs
                 if o.output_type == "display_data")
    assert images >= FIGURES

    assert "converged: True" in stdout(tagged(nb, "solve"))
    assert "Backbone: youngs_modulus = -1.0" in stdout(tagged(nb, "bad-value"))
    below, above = (line for line in stdout(tagged(nb, "stability")).splitlines() if "x Euler" in line)
    assert below.startswith("0.8 x Euler: converged True") and "stable True" in below
    assert above.startswith("1.2 x Euler: converged True") and "stable False" in above
    assert re.search(r"^\d+ of 200 converged", stdout(tagged(nb, "sample")), flags=re.M)
    assert re.search(r"^reach 0\.3\d+ m", stdout(tagged(nb, "optimize")), flags=re.M)
