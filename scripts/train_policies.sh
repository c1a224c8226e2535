#!/usr/bin/env bash
# The training runs behind the learned rows of docs/learning.md's table: PPO on
# Cut-v2 and Pull-v2, each warm-started from its hand-written demonstrator and anchored to it,
# side by side on two cores for 30 minutes, then each evaluated on the 50 unseen seeds beside
# the random, best constant, scripted and demonstrator policies, with the paired comparison of
# the learned policy and its demonstrator; about an hour on a 2-core machine.
# Usage: scripts/train_policies.sh [OUT]   (default out/policies; OUT must not hold a run)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
out="${1:-out/policies}"
mkdir -p "$out"
hyper='{"log_std_init": -4.0, "learn_log_std": false}'
# The time limit as a termination, as the published runs trained (docs/envs.md): the cycle
# time is the task's and the observation carries the time, so there is nothing to bootstrap.
env_kwargs='{"timeout_terminates": true}'
musclecell learn Cut-v2 --steps 3000000 --minutes 30 --envs 1 --out "$out/cut" \
  --hyper "$hyper" --env-kwargs "$env_kwargs" --warm-start table-skimming-knife --warm-start-anchor 10 \
  > "$out/cut-learn.log" 2>&1 &
cut=$!
musclecell learn Pull-v2 --steps 3000000 --minutes 30 --envs 1 --out "$out/pull" \
  --hyper "$hyper" --env-kwargs "$env_kwargs" --warm-start hold-then-pull-away --warm-start-anchor 10 \
  > "$out/pull-learn.log" 2>&1 &
pull=$!
wait "$cut"  # a failed run stops the script (see its log)
wait "$pull"
musclecell evaluate "$out/cut" Cut-v2 --episodes 50 --workers 1 > "$out/cut-evaluate.log" 2>&1 &
cut=$!
musclecell evaluate "$out/pull" Pull-v2 --episodes 50 --workers 1 > "$out/pull-evaluate.log" 2>&1 &
pull=$!
wait "$cut"
wait "$pull"
cat "$out/cut/evaluation/evaluation.md" "$out/pull/evaluation/evaluation.md"
