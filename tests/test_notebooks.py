"""The notebooks in notebooks/: committed with their outputs, and they still run.

The committed copies are executed (readable without running them): every code cell ran in
order, none raised, the figures are stored as small PNGs. A fresh run of each (nbclient, the
python3 kernel, matplotlib's inline backend) must raise nothing, write no files, and draw the
same figures in the same cells as the committed outputs -- a notebook whose code changed
without being re-executed fails here. Regenerate the outputs with

    pip install -e ".[notebooks]"
    jupyter nbconvert --to notebook --execute --inplace \
        --ExecutePreprocessor.record_timing=False notebooks/*.ipynb
"""

import base64
import os
import struct
from pathlib import Path

import pytest

NEEDS = "the notebooks run in a Jupyter kernel: pip install -e \".[test-full]\""
nbformat = pytest.importorskip("nbformat", reason=NEEDS)
nbclient = pytest.importorskip("nbclient", reason=NEEDS)
pytest.importorskip("jupyter_client", reason=NEEDS)
pytest.importorskip("ipykernel", reason=NEEDS)

NOTEBOOKS = sorted((Path(__file__).resolve().parent.parent / "notebooks").glob("*.ipynb"))

#: a committed notebook stays under this size (PNG figures at 72 dpi)
MAX_BYTES = 600_000
#: and so does each stored figure (pixels on a side)
MAX_PIXELS = 1200
#: wall-clock limits of a notebook's run, in seconds: generous, so that only a hung kernel or
#: cell reaches them on a loaded machine (the cells take seconds; the kernel starts in one or
#: two). Each failure names the limit it hit.
CELL_LIMIT = 1800
KERNEL_START_LIMIT = 600
#: after a cell's reply, the wait for its last outputs (nbclient's default, 4 s, can drop a
#: figure on a loaded machine, which would read as a changed notebook)
OUTPUT_LIMIT = 300
#: figures each notebook draws, at least
MIN_FIGURES = {"01_paper_tour": 5, "02_dissipation_landscapes": 5,
               "03_where_laws_disagree": 3, "04_fitting_coefficients": 4}


def _code_cells(nb):
    return [c for c in nb.cells if c.cell_type == "code"]


def _pngs(cell):
    return [o["data"]["image/png"] for o in cell.get("outputs", [])
            if "image/png" in o.get("data", {})]


def _kinds(cell):
    """The output types of a cell, widgets left out, consecutive prints as one (the kernel
    splits a cell's printing into stream messages as it pleases)."""
    kinds = [o["output_type"] for o in cell.get("outputs", [])
             if not any("widget" in k for k in o.get("data", {}))]
    return [k for i, k in enumerate(kinds) if not (k == "stream" and i and kinds[i - 1] == k)]


def _png_size(b64: str) -> tuple[int, int]:
    raw = base64.b64decode(b64)
    assert raw[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", raw[16:24])


def test_notebooks_are_present():
    names = {p.stem for p in NOTEBOOKS}
    assert {"01_paper_tour", "02_dissipation_landscapes", "03_where_laws_disagree"} <= names


def test_python3_kernel_is_available():
    from jupyter_client.kernelspec import KernelSpecManager

    assert "python3" in KernelSpecManager().find_kernel_specs()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_committed_notebook_has_its_outputs(path):
    assert path.stat().st_size < MAX_BYTES, f"{path.name}: store smaller figures"
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    cells = _code_cells(nb)
    # executed top to bottom in one session, nothing raised
    assert [c.execution_count for c in cells] == list(range(1, len(cells) + 1)), path.name
    for c in cells:
        assert not [o for o in c.get("outputs", []) if o.get("output_type") == "error"]
    # the outputs are there: all but set-up cells print or draw something
    assert sum(bool(c.get("outputs")) for c in cells) >= len(cells) - 1, path.name
    pngs = [p for c in cells for p in _pngs(c)]
    assert len(pngs) >= MIN_FIGURES.get(path.stem, 1), path.name
    for p in pngs:
        w, h = _png_size(p)
        assert 100 < w <= MAX_PIXELS and 100 < h <= MAX_PIXELS, (path.name, w, h)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_and_matches_its_outputs(path, tmp_path, monkeypatch):
    # inherited by the kernel: figures are drawn as PNGs, as in the committed outputs
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    committed = nbformat.read(path, as_version=4)
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}},
        timeout=CELL_LIMIT, startup_timeout=KERNEL_START_LIMIT, iopub_timeout=OUTPUT_LIMIT,
        raise_on_iopub_timeout=True)
    try:
        client.execute()
    except nbclient.exceptions.CellTimeoutError as exc:
        pytest.fail(f"{path.name}: wall-clock limit hit -- a cell ran longer than {CELL_LIMIT} s "
                    f"or its outputs came more than {OUTPUT_LIMIT} s after its reply (a hung "
                    f"cell or a machine overloaded far beyond normal): {exc}")
    except RuntimeError as exc:
        if "respond" not in str(exc):
            raise
        pytest.fail(f"{path.name}: wall-clock limit hit -- the python3 kernel did not start "
                    f"within {KERNEL_START_LIMIT} s: {exc}")
    for fresh, old in zip(_code_cells(nb), _code_cells(committed)):
        assert fresh.execution_count is not None
        assert not [o for o in fresh.get("outputs", []) if o.get("output_type") == "error"]
        # the same figures in the same cells (sliders, when ipywidgets is installed, are not
        # counted: the notebook runs without it too)
        assert len(_pngs(fresh)) == len(_pngs(old)), fresh.source[:200]
        assert _kinds(fresh) == _kinds(old), fresh.source[:200]
    assert not any(os.listdir(tmp_path))  # notebooks write no files
