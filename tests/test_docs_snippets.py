"""Every ```python block of README.md and docs/*.md runs as written, in a fresh namespace
and an empty working folder, unless its first line is ``# fragment`` (a piece of a larger
program, said so to the reader)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import use_compile_cache

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FRAGMENT = "# fragment"
_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(page: Path) -> list[tuple[int, str]]:
    """The page's ```python blocks: (line of the opening fence, code)."""
    text = page.read_text(encoding="utf-8")
    return [(text.count("\n", 0, m.start()) + 1, m.group(1)) for m in _BLOCK.finditer(text)]


BLOCKS = [
    (page, line, code)
    for page in PAGES
    for line, code in python_blocks(page)
    if not code.startswith(FRAGMENT + "\n")
]


@pytest.fixture(autouse=True, scope="module")
def cache_dir(shared_compile_cache):
    """What the blocks compile (the derivatives' library) goes to the session's cache."""
    yield from use_compile_cache(shared_compile_cache)


def test_the_pages_have_runnable_blocks():
    assert len(BLOCKS) >= 10
    assert {page.name for page, _, _ in BLOCKS} >= {"README.md", "importing.md", "legs.md"}


@pytest.mark.parametrize(
    ("page", "line", "code"),
    BLOCKS,
    ids=[f"{page.relative_to(ROOT)}:{line}" for page, line, _ in BLOCKS],
)
def test_block_runs_as_written(page, line, code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # padded so that a traceback gives the page's own line numbers
    exec(compile("\n" * line + code, str(page), "exec"), {"__name__": "__main__"})
