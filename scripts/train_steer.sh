#!/usr/bin/env bash
# The learned policy of Steer-v2 in one run of under 60 minutes on a 2-core
# machine (scripts/train_steer.py): DAgger from the expert that steers on the true interface,
# the learner seeing only its own observation, 40 minutes on training seeds (its learning
# curve in OUT/run/learning_curve.csv); the last network or the rounds' average, whichever
# is nearer the interface on 40 validation seeds (300300 on), then beside no steering, the
# steering rule and the ceiling on the 200 unseen seeds 100000-100199, paired on the same
# seeds (the learned policy less the rule: tip distance, success, torn fraction, time,
# cycle time) in OUT/headroom.json.
# Usage: scripts/train_steer.sh [OUT]   (default out/steer; OUT/run must not hold a policy)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
out="${1:-out/steer}"
mkdir -p "$out"
python scripts/train_steer.py --out "$out" --minutes 40 --episodes 16 --workers 2 \
  --eval-episodes 200 2>&1 | tee "$out/train.log"
