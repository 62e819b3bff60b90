#!/usr/bin/env bash
# Issue 64: the pick of the Acrobot-v1 speed study (../acrobot_speed2/, its rule 3) verified as the entry was
# (../verify_acrobot/: 10 fresh seeds, 1M steps, 5 deterministic episodes every 50k steps), on fresh seeds 1010-1019.
# README.md beside this file. Resumable. Run from an activated venv.
#   run.sh CANDIDATE      a config of benchmarks/configs/acrobot_speed2/ (WORKERS=2 for two runs at once)
cd "$(dirname "$0")/../../.." || exit 1
name=${1:?usage: run.sh CANDIDATE}
args=(--env Acrobot-v1 --algos reinforce --config "reinforce=benchmarks/configs/acrobot_speed2/$name.yml"
    --seeds 10 --first-seed 1010 --budget 1000000 --eval-freq 50000 --eval-episodes 5
    --out "benchmarks/results/verify_acrobot_speed/$name" --workers "${WORKERS:-1}" --no-progress)
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
