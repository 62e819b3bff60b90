#!/usr/bin/env bash
# CarRacing-v3 pilot (issue #13): configs of benchmarks/configs/carracing_pilot/ on tuning seeds from
# FIRST_SEED on, at the full 1M budget; finished runs are skipped when
# run again.  Usage: run.sh FIRST_SEED SEEDS CONFIG...
cd "$(dirname "$0")/../../.." || exit 1
first=$1 seeds=$2; shift 2
for name in "$@"; do
    echo "\$ sb3-reinforce compare --env CarRacing-v3 --algos reinforce --seeds $seeds --first-seed $first --budget 1000000 --reinforce-config benchmarks/configs/carracing_pilot/$name.yml --out benchmarks/results/carracing_pilot/$name --workers 1 --no-progress"
    sb3-reinforce compare --env CarRacing-v3 --algos reinforce --seeds "$seeds" --first-seed "$first" --budget 1000000 \
        --reinforce-config "benchmarks/configs/carracing_pilot/$name.yml" \
        --out "benchmarks/results/carracing_pilot/$name" --workers 1 --no-progress
done
