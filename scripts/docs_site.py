"""The documentation site's two steps around Sphinx (``scripts/build_docs.sh`` runs them).

``python scripts/docs_site.py stage STAGE`` lays out the site's sources in ``STAGE``:

- ``index.md``: README.md, the home page, with the site's table of contents
  (``docs/sphinx/toctree.md``);
- ``docs/``: the user guide, docs/*.md, where it is in the repository (links stay valid);
- ``api.md``: the API reference (``docs/sphinx/api.md``; autosummary fills ``api/``);
- ``notebooks/``: the notebooks with their outputs. Taken from the folder
  ``$STEWART_PIN_EXECUTED_NOTEBOOKS`` where the test suite wrote them
  (tests/test_notebooks.py: one execution per notebook and CI run) when the copy there is
  current (same code cells, newer than the notebook, src/*.py and models/), else executed
  here, in notebooks/ as Jupyter would (nothing is written there: the test checks it);
- ``gallery.md``: one entry per notebook, its title, first paragraph and first figure.

``python scripts/docs_site.py check-links SITE`` fails on any relative link or image of
the built HTML whose file is missing (Sphinx checks the cross-references; this checks the
pages as a browser would follow them).
"""

from __future__ import annotations

import argparse
import base64
import os
import shutil
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

ROOT = Path(__file__).resolve().parent.parent
#: The gallery's order; notebooks not listed follow by name.
GALLERY_ORDER = (
    "quick_tour",
    "leg_architectures",
    "simulation_and_control",
    "identification",
    "trajectory_optimisation",
    "payload",
    "design_studies",
)
CACHE_ENV = "STEWART_PIN_EXECUTED_NOTEBOOKS"
TIMEOUT = 600  # [s] per cell


def _code(nb) -> list[str]:
    return [c.source for c in nb.cells if c.cell_type == "code"]


def _newest_source(notebook: Path) -> float:
    """The newest modification time [s] of the notebook, the modules of src/ and the model
    files (not the bytecode caches, which any later import writes)."""
    sources = [*(ROOT / "src").rglob("*.py"), *(ROOT / "models").rglob("*")]
    times = [notebook.stat().st_mtime]
    times += [p.stat().st_mtime for p in sources if p.is_file() and p.suffix != ".pyc"]
    return max(times)


def cached_execution(path: Path, cache: Path):
    """The execution of the notebook at ``path`` in the folder ``cache`` if it is current
    (same code cells, newer than its sources), else None."""
    import nbformat

    copy = cache / path.name
    if not copy.is_file() or copy.stat().st_mtime < _newest_source(path):
        return None
    nb = nbformat.read(copy, as_version=4)
    return nb if _code(nb) == _code(nbformat.read(path, as_version=4)) else None


def executed_notebook(path: Path):
    """The notebook at ``path`` with its outputs: the test suite's execution when current,
    else executed now."""
    import nbformat

    cache = os.environ.get(CACHE_ENV)
    if cache and (nb := cached_execution(path, Path(cache))) is not None:
        print(f"{path.name}: the test suite's execution (in {cache})")
        return nb
    import nbclient

    committed = nbformat.read(path, as_version=4)
    print(f"{path.name}: executing", flush=True)
    os.environ.pop("MPLBACKEND", None)  # the kernel's own inline backend
    nbclient.NotebookClient(
        committed,
        timeout=TIMEOUT,
        kernel_name="python3",
        resources={"metadata": {"path": str(path.parent)}},
    ).execute()
    return committed


def _first_png(nb) -> bytes | None:
    for cell in nb.cells:
        for output in cell.get("outputs", []) if cell.cell_type == "code" else []:
            if "image/png" in output.get("data", {}):
                return base64.b64decode(output["data"]["image/png"])
    return None


def _title_and_summary(nb) -> tuple[str, str]:
    """The first markdown cell's heading and first paragraph."""
    text = next(c.source for c in nb.cells if c.cell_type == "markdown")
    paragraphs = [p.strip() for p in text.split("\n\n") if p.strip()]
    title = paragraphs[0].lstrip("#").strip()
    prose = [p for p in paragraphs[1:] if not p.startswith(("#", "-", "|")) and p[-1] != ":"]
    summary = prose[0] if prose else ""
    # its links are relative to notebooks/, the gallery's to the site's root
    return title, " ".join(summary.split()).replace("](../", "](")


def stage(dest: Path) -> None:
    import nbformat

    if dest.exists():
        shutil.rmtree(dest)
    (dest / "docs").mkdir(parents=True)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    toctree = (ROOT / "docs" / "sphinx" / "toctree.md").read_text(encoding="utf-8")
    (dest / "index.md").write_text(readme + toctree, encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        shutil.copy2(page, dest / "docs" / page.name)
    shutil.copy2(ROOT / "docs" / "sphinx" / "api.md", dest / "api.md")

    notebooks = sorted(
        (ROOT / "notebooks").glob("*.ipynb"),
        key=lambda p: (GALLERY_ORDER.index(p.stem) if p.stem in GALLERY_ORDER else 99, p.stem),
    )
    (dest / "notebooks").mkdir()
    (dest / "gallery").mkdir()
    entries, pages = [], []
    for path in notebooks:
        nb = executed_notebook(path)
        png = _first_png(nb)
        if png is None:
            sys.exit(f"error: {path.name} shows no figure; the gallery needs one")
        nbformat.write(nb, dest / "notebooks" / path.name)
        (dest / "gallery" / f"{path.stem}.png").write_bytes(png)
        title, summary = _title_and_summary(nb)
        pages.append(f"notebooks/{path.stem}")
        entries.append(
            f"## [{title}](notebooks/{path.name})\n\n"
            f"[![{title}](gallery/{path.stem}.png){{w=420px}}](notebooks/{path.name})\n\n"
            f"{summary}\n"
        )
    gallery = [
        "# Gallery\n",
        "The notebooks of `notebooks/`, run top to bottom, with their figures (open one in "
        "Jupyter to run it yourself; each writes nothing outside a temporary folder).\n",
        "```{toctree}\n:hidden:\n\n" + "\n".join(pages) + "\n```\n",
        *entries,
    ]
    (dest / "gallery.md").write_text("\n".join(gallery), encoding="utf-8")


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.targets: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if value and (tag, name) in {("a", "href"), ("img", "src"), ("link", "href")}:
                self.targets.append(value)
            if value and (tag, name) == ("script", "src"):
                self.targets.append(value)


def check_links(site: Path) -> None:
    broken = []
    pages = sorted(site.rglob("*.html"))
    for page in pages:
        parser = _Links()
        parser.feed(page.read_text(encoding="utf-8"))
        for target in parser.targets:
            url = urlsplit(target)
            if url.scheme or url.netloc or not url.path:
                continue  # external, or an anchor in the page itself
            if not (page.parent / unquote(url.path)).exists():
                broken.append(f"{page.relative_to(site)}: {target}")
    if broken:
        sys.exit("error: broken links in the site:\n  " + "\n  ".join(broken))
    print(f"links checked: {len(pages)} pages, no broken relative link")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("stage", help="lay out the site's sources").add_argument("dest", type=Path)
    sub.add_parser("check-links", help="check the built site").add_argument("site", type=Path)
    args = parser.parse_args()
    if args.command == "stage":
        stage(args.dest)
    else:
        check_links(args.site)


if __name__ == "__main__":
    main()
