#!/usr/bin/env bash
# The test suite: the linter, the docs site built with warnings as errors (a broken reference
# or docstring fails here), then the fast tests, the docs pages' snippets among them
# (`scripts/test.sh -m slow` runs the long physics ones and the snippets marked slow).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
ruff check .
site="$(mktemp -d)"
trap 'rm -rf "$site"' EXIT
sphinx-build -W --keep-going -q -b html docs "$site"
# tests/test_docs.py checks this build's API reference instead of building the site again.
export MUSCLECELL_DOCS_SITE="$site"
# A crash in a process's native teardown prints its Python stack (tests/workerexit.py fails
# the run on it).
export PYTHONFAULTHANDLER=1
# One test process per core (pytest-xdist): the tests share nothing but the read-only tree.
python -m pytest -n auto --dist worksteal "$@"
