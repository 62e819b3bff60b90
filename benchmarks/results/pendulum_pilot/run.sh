#!/usr/bin/env bash
# Pendulum-v1 pilot (issue #13): configs of benchmarks/configs/pendulum_pilot/ on tuning seed 100 (and 101 for
# the ones named with --seeds 2), at 300k steps (first round) and at the full 1M budget; finished runs are
# skipped when run again.  Usage: run.sh BUDGET SEEDS CONFIG...
cd "$(dirname "$0")/../../.." || exit 1
budget=$1 seeds=$2; shift 2
for name in "$@"; do
    sb3-reinforce compare --env Pendulum-v1 --algos reinforce --seeds "$seeds" --first-seed 100 --budget "$budget" \
        --reinforce-config "benchmarks/configs/pendulum_pilot/$name.yml" \
        --out "benchmarks/results/pendulum_pilot/$([ "$budget" = 300000 ] && echo "$name" || echo "1m/$name")" \
        --workers 1 --no-progress
done
