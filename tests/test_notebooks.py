"""The notebooks run top to bottom under a Jupyter kernel as a user opens them (in
``notebooks/``, matplotlib's inline backend): each shows its figures inline and writes
nothing into the repository.

One execution per notebook serves both checks. With ``STEWART_PIN_EXECUTED_NOTEBOOKS`` set
to a folder, the executed notebook is also written there, for ``scripts/build_docs.sh`` to
render the gallery without executing it again (.ci/run sets it).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
#: The figures (``image/png`` outputs) each notebook shows, at least.
FIGURES = {
    "design_studies": 3,
    "identification": 1,
    "leg_architectures": 3,
    "payload": 1,
    "quick_tour": 1,
    "simulation_and_control": 1,
    "trajectory_optimisation": 2,
}
#: Folders a run may write in without changing the repository: caches, virtual
#: environments, build outputs (all ignored by git).
_UNTRACKED = {".git", ".venv", "__pycache__", ".pytest_cache", ".ruff_cache", ".mypy_cache"}
_UNTRACKED |= {".hypothesis", "build", "site", "out"}


def repository_files(root: Path) -> dict[str, tuple[int, int]]:
    """Every file under ``root`` but the untracked folders: relative path -> (size, mtime)."""
    files = {}
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if d not in _UNTRACKED and not d.endswith(".egg-info")]
        for name in names:
            stat = (Path(folder) / name).stat()
            files[str((Path(folder) / name).relative_to(root))] = (stat.st_size, stat.st_mtime_ns)
    return files


def image_outputs(nb) -> int:
    """How many ``image/png`` outputs the executed notebook holds."""
    return sum(
        "image/png" in output.get("data", {})
        for cell in nb.cells
        if cell.cell_type == "code"
        for output in cell.outputs
    )


def test_every_notebook_has_an_expected_figure_count():
    assert sorted(FIGURES) == [p.stem for p in NOTEBOOKS]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_shows_its_figures_and_writes_nothing(path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    # The kernel's own default, the inline backend (ipykernel sets it when MPLBACKEND is unset).
    monkeypatch.delenv("MPLBACKEND", raising=False)
    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), (
        f"{path.name} is committed with outputs: strip them"
    )
    before = repository_files(ROOT)
    nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    ).execute()
    after = repository_files(ROOT)
    changed = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
    assert not changed, f"{path.name} wrote into the repository: {changed}"
    assert image_outputs(nb) >= FIGURES[path.stem], (
        f"{path.name} shows {image_outputs(nb)} figures inline, expected {FIGURES[path.stem]}"
    )
    if folder := os.environ.get("STEWART_PIN_EXECUTED_NOTEBOOKS"):
        Path(folder).mkdir(parents=True, exist_ok=True)
        nbformat.write(nb, Path(folder) / path.name)
