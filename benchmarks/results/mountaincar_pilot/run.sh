#!/usr/bin/env bash
# MountainCar-v0 pilot (issue #13): configs of benchmarks/configs/mountaincar_pilot/ on tuning seeds from
# FIRST_SEED on, at the full 1M budget, evaluated on the standard 200-step env; finished runs are skipped when
# run again.  Usage: run.sh FIRST_SEED SEEDS CONFIG...
cd "$(dirname "$0")/../../.." || exit 1
first=$1 seeds=$2; shift 2
for name in "$@"; do
    echo "\$ sb3-reinforce compare --env MountainCar-v0 --algos reinforce --seeds $seeds --first-seed $first --budget 1000000 --reinforce-config benchmarks/configs/mountaincar_pilot/$name.yml --out benchmarks/results/mountaincar_pilot/$name --workers 1 --no-progress"
    sb3-reinforce compare --env MountainCar-v0 --algos reinforce --seeds "$seeds" --first-seed "$first" --budget 1000000 \
        --reinforce-config "benchmarks/configs/mountaincar_pilot/$name.yml" \
        --out "benchmarks/results/mountaincar_pilot/$name" --workers 1 --no-progress
done
