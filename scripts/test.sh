#!/usr/bin/env bash
# The test suite: the linter, the docs site built with warnings as errors (a broken reference
# or docstring fails here), then the fast tests, the docs pages' snippets among them
# (`scripts/test.sh -m slow` runs the long ones instead, the snippets marked slow among them).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
ruff check .
site="$(mktemp -d)"
scratch="$(mktemp -d)"
trap 'rm -rf "$site" "$scratch"' EXIT
# While the docs build (on every core), an episode compiles the tissue's numba kernels into
# numba's cache, which the test processes then load instead of each compiling them at its
# first episode.
python -m cell.cli run scenarios/quick.toml --out "$scratch/warm.json" --quiet \
  > "$scratch/warm.log" 2>&1 &
warm=$!
sphinx-build -j auto -W --keep-going -q -b html docs "$site"
wait "$warm" || echo "test.sh: the warm-up episode failed, the tests compile the kernels" \
  "themselves: $(tail -n 1 "$scratch/warm.log")" >&2
# The project's modules compiled once: where PYTHONDONTWRITEBYTECODE is set, every process the
# tests start (the snippets' commands, the pools' workers) would compile them again.
python -m compileall -q -j 0 cell envs controllers tests
# tests/test_docs.py checks this build's API reference instead of building the site again.
export MUSCLECELL_DOCS_SITE="$site"
# A crash in a process's native teardown prints its Python stack (tests/workerexit.py fails
# the run on it).
export PYTHONFAULTHANDLER=1
# One test process per core (pytest-xdist): the tests share nothing but the read-only tree.
python -m pytest -n auto --dist worksteal "$@"
