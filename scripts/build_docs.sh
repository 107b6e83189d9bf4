#!/usr/bin/env bash
# The documentation site, into site/ (open site/index.html): the README as the home page,
# the user guide (docs/), the gallery of the notebooks with their figures, the performance
# page and the API reference generated from the docstrings. Sphinx with MyST-NB and
# autodoc; warnings are errors (a broken cross-reference or page link, a docstring autodoc
# cannot read), then every relative link of the built pages is checked.
#
# Needs the docs extra: pip install -e ".[docs]". PYTHON picks the interpreter (default
# python3). The notebooks are executed unless STEWART_PIN_EXECUTED_NOTEBOOKS names the
# folder where the test suite wrote its executions (tests/test_notebooks.py; .ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
"$PYTHON" scripts/docs_site.py stage build/docs-src
# Built in build/ (MyST-NB writes the notebooks' figures beside its output folder), then
# moved to site/.
rm -rf site build/docs-html build/docs-doctrees build/jupyter_execute
"$PYTHON" -m sphinx -b html -W --keep-going -q -E -d build/docs-doctrees -c docs/sphinx \
    build/docs-src build/docs-html
mv build/docs-html site
"$PYTHON" scripts/docs_site.py check-links site
echo "site built: site/index.html"
