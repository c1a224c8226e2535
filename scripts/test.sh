#!/usr/bin/env bash
# The test suite (fast tests; `scripts/test.sh -m slow` runs the long physics ones).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
ruff check .
python -m pytest "$@"
