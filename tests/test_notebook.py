"""Execute notebooks/01_tour.ipynb end to end with a tiny training budget (nbclient)."""

from __future__ import annotations

import os

import nbformat
import pytest
from nbclient import NotebookClient
from repo import ROOT

NOTEBOOK = ROOT / "notebooks" / "01_tour.ipynb"


def test_tour_notebook_runs_with_a_tiny_budget(monkeypatch):
    monkeypatch.setenv("SPINE_TOUR_BUDGET", "256")  # the notebook reads it: 256 env steps, quick suite
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(ROOT / "notebooks")}})
    client.execute()
    outputs = "".join(
        o.get("text", "") + str(o.get("data", {}).get("text/plain", ""))
        for c in nb.cells
        if c.cell_type == "code"
        for o in c.get("outputs", [])
    )
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors
    assert "scenario group: disturbed" in outputs  # the evaluation table was printed
    assert "ppo_tour" in outputs and "pid" in outputs
    images = [o for c in nb.cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) >= 4


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__, "-q"])
