#!/usr/bin/env bash
# Issue 64's Acrobot-v1 speed study (README.md beside this file), resumable: finished runs are skipped.
#   run.sh [CANDIDATE ...]     default: entry v10 e2 e2_v10 e4
# Seed-major (every candidate on seed 100, then 101, ...), one run at a time, 1M steps, 5 deterministic evaluation
# episodes every 50k steps. Runs go to benchmarks/results/acrobot_speed/CANDIDATE/. Run from the repository root.
set -e
cd "$(dirname "$0")/../../.."
candidates=("$@")
[ ${#candidates[@]} -gt 0 ] || candidates=(entry v10 e2 e2_v10 e4)
for seed in 100 101 102 103; do
    for candidate in "${candidates[@]}"; do
        config=(--config "reinforce=benchmarks/configs/acrobot_speed/$candidate.yml")
        [ "$candidate" = entry ] && config=()   # the zoo entry itself (zoo_configs/reinforce.yml), compare's default
        args=(--env Acrobot-v1 --algos reinforce "${config[@]}"
            --seeds 1 --first-seed "$seed" --budget 1000000 --eval-freq 50000 --eval-episodes 5
            --out "benchmarks/results/acrobot_speed/$candidate" --workers 1 --no-progress)
        echo "\$ sb3-reinforce compare ${args[*]}"
        sb3-reinforce compare "${args[@]}"
    done
done
