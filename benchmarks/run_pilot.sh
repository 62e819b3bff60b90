#!/usr/bin/env bash
# A pilot of issue #13: configs of benchmarks/configs/<PILOT>/ trained with `sb3-reinforce compare` on tuning
# seeds FIRST_SEED.., at the full 1M-step budget, into benchmarks/results/<PILOT>/<CONFIG>/; finished runs are
# skipped and interrupted ones resume from their last evaluation when run again.
# Usage: run_pilot.sh ENV PILOT FIRST_SEED SEEDS CONFIG...
cd "$(dirname "$0")/.." || exit 1
env_id=$1 pilot=$2 first=$3 seeds=$4; shift 4
for name in "$@"; do
    args=(--env "$env_id" --algos reinforce --seeds "$seeds" --first-seed "$first" --budget 1000000
        --reinforce-config "benchmarks/configs/$pilot/$name.yml" --out "benchmarks/results/$pilot/$name" --workers 1 --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
done
