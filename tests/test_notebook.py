"""examples/quickstart.ipynb runs from top to bottom in a fresh kernel (so it never rots), and
is committed without outputs."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import nbclient
import nbformat
import pytest

EXAMPLES = Path(__file__).parents[1] / "examples"
NOTEBOOK = EXAMPLES / "quickstart.ipynb"
DATA = Path(__file__).parents[1] / "data" / "reference-study"


def test_the_notebook_is_committed_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code
    assert all(c.outputs == [] and c.execution_count is None for c in code)


@pytest.fixture
def kernel(tmp_path, monkeypatch) -> str:
    """A kernel spec running this interpreter's ipykernel, found before any of the user's
    (no `ipykernel install` needed)."""
    spec = tmp_path / "jupyter" / "kernels" / "evtribo-test"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (evtribo tests)", "language": "python"}), encoding="utf-8")
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    monkeypatch.setenv("JUPYTER_RUNTIME_DIR", str(tmp_path / "runtime"))
    monkeypatch.setenv("IPYTHONDIR", str(tmp_path / "ipython"))
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    return "evtribo-test"


def test_the_notebook_runs(kernel):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name=kernel,
                                     resources={"metadata": {"path": str(EXAMPLES)}})
    before = {p: p.stat().st_mtime_ns for d in (EXAMPLES, DATA) for p in d.rglob("*")}
    started = time.perf_counter()
    client.execute()  # raises CellExecutionError, with the cell and its traceback, on a fault
    elapsed = time.perf_counter() - started
    after = {p: p.stat().st_mtime_ns for d in (EXAMPLES, DATA) for p in d.rglob("*")}
    assert after == before  # the notebook writes nothing beside itself or into the study
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    text = "\n".join(o.get("text", "") + json.dumps(o.get("data", {}).get("text/plain", ""))
                     for o in outputs)
    assert "18 trials of P01, P02, P03" in text
    assert "18 of 18 trials analysed" in text
    assert "h_L (µm)" in text or "h_L (\\u00b5m)" in text
    assert "read back: the same electrostatic table" in text
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 3  # the trial's forces, the headline figure, a per-subject figure
    print(f"the notebook ran in {elapsed:.1f} s")
