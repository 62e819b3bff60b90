#!/usr/bin/env bash
# MuJoCo tuning study (README.md beside this file): one candidate on one env, tuning seeds 100 and 101 (both at
# once, one core each), 3M steps, resumable (a run continues from its last evaluation's checkpoint; finished runs
# are skipped). Usage: run.sh CONFIG ENV. Each (config, env) writes to benchmarks/results/mujoco_tuning/CONFIG/ENV/.
# Run from an activated venv with the mujoco and compare extras.
cd "$(dirname "$0")/../../.." || exit 1
config=${1:?usage: run.sh CONFIG ENV}
env_id=${2:?usage: run.sh CONFIG ENV}
# The solve threshold is the published number to beat (README.md), read off benchmarks/published/reinforce_mujoco.csv
# by benchmarks/mujoco_thresholds.py as mujoco_table.sh reads it: the higher of Tianshou's REINFORCE at 3M and Spinning
# Up's VPG at 3M, so "steps to reach" reads when a seed first matched both.
read -r _ threshold < <(python benchmarks/mujoco_thresholds.py "$env_id") || exit 1
args=(--env "$env_id" --algos reinforce --seeds 2 --first-seed 100 --budget 3000000 --eval-freq 50000
    --eval-episodes 10 --threshold "$threshold" --workers "${WORKERS:-2}"
    --out "benchmarks/results/mujoco_tuning/$config/$env_id" --no-progress
    --reinforce-config "benchmarks/configs/mujoco_tuning/$config.yml")
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
