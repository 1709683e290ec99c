"""The example notebook runs end to end (nbclient, a real kernel) and shows the figure."""

import os
from pathlib import Path

import pytest

ROOT = Path(os.environ.get("PILLAR_PIPE_ROOT", Path(__file__).resolve().parents[2]))
NOTEBOOK = ROOT / "examples" / "trackpy_to_crossover.ipynb"


def test_notebook_runs_and_shows_the_crossover_figure(tmp_path):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    # Run where a user would open it (examples/); outputs are not written back.
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    last = nb.cells[-1]
    assert any("image/png" in o.get("data", {}) for o in last.outputs), last.outputs
    printed = "".join(o.get("text", "") for o in last.outputs)
    assert "Θ =" in printed and "η_c =" in printed, printed
