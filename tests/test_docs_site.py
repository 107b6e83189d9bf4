"""scripts/docs_site.py, the documentation site's steps around Sphinx: the test suite's
notebook executions are reused only when current, and the link check finds a broken link."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("docs_site", ROOT / "scripts" / "docs_site.py")
docs_site = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(docs_site)

NOTEBOOK = ROOT / "notebooks" / "quick_tour.ipynb"


def _executed_copy(folder: Path, edit=None) -> Path:
    """A copy of the notebook in ``folder`` with one output (its code cells edited by
    ``edit``), as the test suite writes it."""
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    code[0].outputs = [nbformat.v4.new_output("stream", name="stdout", text="ran\n")]
    if edit is not None:
        edit(code)
    folder.mkdir(exist_ok=True)
    nbformat.write(nb, folder / NOTEBOOK.name)
    return folder / NOTEBOOK.name


def test_a_current_execution_is_reused(tmp_path):
    _executed_copy(tmp_path)
    nb = docs_site.cached_execution(NOTEBOOK, tmp_path)
    assert nb is not None
    assert next(c for c in nb.cells if c.cell_type == "code").outputs[0]["text"] == "ran\n"


def test_a_stale_execution_is_not_reused(tmp_path):
    assert docs_site.cached_execution(NOTEBOOK, tmp_path) is None  # none
    edited = _executed_copy(tmp_path / "edited", lambda code: code[0].update(source="1"))
    assert docs_site.cached_execution(NOTEBOOK, edited.parent) is None  # other code
    older = _executed_copy(tmp_path / "older")
    newest = docs_site._newest_source(NOTEBOOK)
    os.utime(older, (newest - 10.0, newest - 10.0))
    assert docs_site.cached_execution(NOTEBOOK, older.parent) is None  # older than the code


def test_the_link_check_finds_a_missing_page(tmp_path, capsys):
    (tmp_path / "api").mkdir()
    (tmp_path / "index.html").write_text(
        '<a href="api/robot.html#x">API</a> <a href="https://example.org/a">out</a>'
        '<a href="#top">top</a> <img src="_images/fig.png">'
    )
    (tmp_path / "api" / "robot.html").write_text('<a href="../index.html">home</a>')
    with pytest.raises(
        SystemExit, match=r"broken links in the site:\n  index.html: _images/fig.png$"
    ):
        docs_site.check_links(tmp_path)
    (tmp_path / "_images").mkdir()
    (tmp_path / "_images" / "fig.png").write_bytes(b"")
    docs_site.check_links(tmp_path)
    assert "no broken relative link" in capsys.readouterr().out
