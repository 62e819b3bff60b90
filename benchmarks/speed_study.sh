#!/usr/bin/env bash
# A speed study of one task's REINFORCE entry (issue 64; the plan and rule: the study folder's README.md), resumable:
# finished runs are skipped, interrupted ones continue from their last evaluation's checkpoint.
#   speed_study.sh ENV STUDY CANDIDATE ...
# Candidate `entry` is the zoo entry itself (zoo_configs/reinforce.yml, compare's default); any other is
# benchmarks/configs/STUDY/CANDIDATE.yml. Seed-major (every candidate on seed 100, then 101, 102, 103; SEEDS="..." for
# others), one run at a time, 1M steps, 5 deterministic evaluation episodes every 50k steps. Runs go to
# benchmarks/results/STUDY/CANDIDATE/.
set -e
cd "$(dirname "$0")/.."
env=${1:?usage: speed_study.sh ENV STUDY CANDIDATE ...}
study=${2:?usage: speed_study.sh ENV STUDY CANDIDATE ...}
shift 2
for seed in ${SEEDS:-100 101 102 103}; do
    for candidate in "$@"; do
        config=(--config "reinforce=benchmarks/configs/$study/$candidate.yml")
        [ "$candidate" = entry ] && config=()
        args=(--env "$env" --algos reinforce "${config[@]}"
            --seeds 1 --first-seed "$seed" --budget 1000000 --eval-freq 50000 --eval-episodes 5
            --out "benchmarks/results/$study/$candidate" --workers 1 --no-progress)
        echo "\$ sb3-reinforce compare ${args[*]}"
        sb3-reinforce compare "${args[@]}"
    done
done
