#!/usr/bin/env bash
# The main job: the default scripted cutting episode. Writes out/default.rrd (checked with
# `rerun rrd verify`) and out/default-summary.json.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
musclecell run scenarios/default.toml --rerun out/default.rrd --out out/default-summary.json "$@"
rerun rrd verify out/default.rrd
