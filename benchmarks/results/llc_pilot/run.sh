#!/usr/bin/env bash
# LunarLanderContinuous-v3 pilot (issue #13): configs of benchmarks/configs/llc_pilot/ on tuning seeds 100..,
# at the full 1M budget; finished runs are skipped when run again.  Usage: run.sh SEEDS CONFIG...
cd "$(dirname "$0")/../../.." || exit 1
seeds=$1; shift
for name in "$@"; do
    sb3-reinforce compare --env LunarLanderContinuous-v3 --algos reinforce --seeds "$seeds" --first-seed 100 \
        --budget 1000000 --reinforce-config "benchmarks/configs/llc_pilot/$name.yml" \
        --out "benchmarks/results/llc_pilot/$name" --workers 1 --no-progress
done
