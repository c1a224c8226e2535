#!/usr/bin/env bash
# The project's pictures, made by the project: docs/images/cell.png is the default scenario's
# cell at the start of its episode, drawn by `musclecell render` (headless, MUJOCO_GL=egl).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
export MUJOCO_GL="${MUJOCO_GL:-egl}"
musclecell render scenarios/default.toml --out docs/images/cell.png --width 1280 --height 720 "$@"
