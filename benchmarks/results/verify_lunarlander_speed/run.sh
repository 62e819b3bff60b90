#!/usr/bin/env bash
# Issue 64: the pick of the LunarLander-v3 speed study (../lunarlander_speed/, its rule 3) verified as the entry was
# (../verify_lunarlander_gamma0995/: 10 fresh seeds, 1M steps, 5 deterministic episodes every 50k steps), on fresh
# seeds 1020-1029. README.md beside this file. Resumable. Run from an activated venv.
#   run.sh CANDIDATE      a config of benchmarks/configs/lunarlander_speed/ (WORKERS=2 for two runs at once)
cd "$(dirname "$0")/../../.." || exit 1
name=${1:?usage: run.sh CANDIDATE}
args=(--env LunarLander-v3 --algos reinforce --config "reinforce=benchmarks/configs/lunarlander_speed/$name.yml"
    --seeds 10 --first-seed 1020 --budget 1000000 --eval-freq 50000 --eval-episodes 5
    --out "benchmarks/results/verify_lunarlander_speed/$name" --workers "${WORKERS:-1}" --no-progress)
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
