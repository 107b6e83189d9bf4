"""Sphinx configuration of the documentation site (``scripts/build_docs.sh``).

The site's sources are staged by ``scripts/stage_docs.py`` (README.md as the home page,
docs/*.md, the executed notebooks, the gallery, the API reference of this folder) and
built with warnings as errors: a broken internal link, a missing page or a docstring
autodoc cannot read fails the build.
"""

from __future__ import annotations

import stewart_pin

project = "stewart-pin"
author = "the stewart-pin authors"
copyright = "the stewart-pin authors, BSD-3-Clause"
release = version = stewart_pin.__version__

extensions = [
    "myst_nb",  # Markdown pages (MyST) and the notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",  # the docstrings' Google style (Args:, Returns:, Raises:)
    "sphinx.ext.viewcode",
]
root_doc = "index"
exclude_patterns = ["sphinx/**", "jupyter_execute/**"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# Markdown: GitHub's heading anchors (docs link to `legs.md#singularities`).
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "attrs_inline"]
# The notebooks are rendered with the outputs of their one execution (the test suite's, or
# the staging script's): never executed here.
nb_execution_mode = "off"
nb_merge_streams = True

# The API reference: one page per public module, the typed signatures and the docstrings.
autosummary_generate = True
autosummary_imported_members = False
# Each object on the page of the module that defines it (a package's __all__ re-exports
# it: documented once, so that every cross-reference has one target).
autodoc_default_options = {
    "members": True,
    "member-order": "bysource",
    "show-inheritance": True,
    "ignore-module-all": True,
}
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False

html_theme = "furo"
html_title = f"stewart-pin {release}"
html_show_sourcelink = False


def setup(app):
    """Napoleon reads only the docstrings of modules, classes and functions: the one-line
    docstrings of properties and attributes are prose, whose first colon napoleon would take
    for a ``type: description`` split."""
    from sphinx.ext.napoleon import _process_docstring

    for listener in list(app.events.listeners["autodoc-process-docstring"]):
        if listener.handler is _process_docstring:
            app.disconnect(listener.id)

    def process(app, what, name, obj, options, lines):
        if what not in {"attribute", "property", "data"}:
            _process_docstring(app, what, name, obj, options, lines)

    app.connect("autodoc-process-docstring", process)
