"""Execute every notebook in ``notebooks/`` (jupytext percent scripts) with small settings.

Each ``notebooks/*.py`` is converted with jupytext and run cell by cell by nbclient in a
kernel of *this* interpreter (the venv's ipykernel), with ``HDPBSID_NOTEBOOK_SMALL=1`` and
matplotlib's Agg backend.  The notebooks assert their own key facts (verification of a
derived basis, eigenvalue error bounds, ...), so a clean run is a meaningful test.
"""

from __future__ import annotations

import gc
import json
import os
import sys
from pathlib import Path

# the notebooks extra (installed by make test): a missing package must fail, not skip
import ipykernel  # noqa: F401
import jupytext
import nbclient
import pytest
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import KernelManager
from nbformat.v4 import new_code_cell

NOTEBOOKS = sorted((Path(__file__).resolve().parent.parent / "notebooks").glob("[0-9]*.py"))
KERNEL = "slbasis-hdpbsid-test"


@pytest.fixture(scope="module")
def kernel_manager_factory(tmp_path_factory: pytest.TempPathFactory):
    """Kernel managers for a private kernelspec that runs ``sys.executable``.

    Nothing is registered globally: the spec lives in a temporary directory and only this
    module's :class:`KernelSpecManager` looks there.
    """
    root = tmp_path_factory.mktemp("kernels")
    spec_dir = root / KERNEL
    spec_dir.mkdir()
    spec = {
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "slbasis-hdpbsid test kernel",
        "language": "python",
    }
    (spec_dir / "kernel.json").write_text(json.dumps(spec))

    def make() -> KernelManager:
        ksm = KernelSpecManager(kernel_dirs=[str(root)], ensure_native_kernel=False)
        return KernelManager(kernel_name=KERNEL, kernel_spec_manager=ksm)

    return make


def test_notebooks_found() -> None:
    assert len(NOTEBOOKS) >= 3, NOTEBOOKS


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path: Path, kernel_manager_factory, monkeypatch, tmp_path) -> None:
    monkeypatch.setenv("HDPBSID_NOTEBOOK_SMALL", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for name in ("FIGDIR", "OUT", "RUNS", "JOBS"):  # a user's overrides must not leak in
        monkeypatch.delenv(f"HDPBSID_NOTEBOOK_{name}", raising=False)
    # one thread per BLAS: the test suite runs notebooks in parallel on 2 cores
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    nb = jupytext.read(path)
    # first cell: the kernel must be this interpreter (the venv), not some global python
    check = f"import sys\nassert sys.executable == {sys.executable!r}, sys.executable"
    nb.cells.insert(0, new_code_cell(check))
    km = kernel_manager_factory()
    client = nbclient.NotebookClient(
        nb,
        km=km,
        timeout=300,
        allow_errors=False,
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()
    gc.collect()  # finalise the client's zmq sockets here, not inside a later test
    errors = [
        out
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors, errors
    assert os.environ["HDPBSID_NOTEBOOK_SMALL"] == "1"
