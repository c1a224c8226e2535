#!/usr/bin/env bash
# A sketch, not yet run: the learned policy of Steer-v1 (issue 36), one script of under 60
# minutes on a 2-core machine. PPO on two envs (each env process collects its own rollout
# segments) for 50 minutes, warm-started from the steering rule (the `steering-knife`
# demonstrator, whose defaults must first be the settings scripts/steer_headroom.py tuned),
# the action noise fixed small and no anchor, so that PPO may move off the rule where the
# off-interface reward pays; then the learned policy beside no steering, the rule and the
# ceiling on the 50 unseen seeds 100000-100049, paired on the same seeds (the learned policy
# less the rule: the tip's mean distance to the true interface, and the success).
# Usage: scripts/train_steer.sh [OUT]   (default out/steer; OUT must not hold a run)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
out="${1:-out/steer}"
mkdir -p "$out"
musclecell learn Steer-v1 --envs 2 --steps 1500000 --minutes 50 --out "$out/run" \
  --warm-start steering-knife --warm-start-episodes 24 \
  --hyper '{"log_std_init": -2.5, "learn_log_std": false, "n_steps": 1024}' \
  > "$out/learn.log" 2>&1
python scripts/steer_headroom.py --rule '{}' --learned "$out/run" --episodes 50 \
  --workers 2 --json "$out/headroom.json" | tee "$out/headroom.log"
