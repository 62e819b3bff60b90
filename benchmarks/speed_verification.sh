#!/usr/bin/env bash
# A speed study's pick verified on 10 fresh seeds as its task's entry was (issue 64; the criteria: the verification
# folder's README.md): 1M steps, 5 deterministic evaluation episodes every 50k steps, resumable.
#   speed_verification.sh ENV STUDY FIRST_SEED CANDIDATE
# Trains benchmarks/configs/STUDY/CANDIDATE.yml on seeds FIRST_SEED to FIRST_SEED + 9 into
# benchmarks/results/verify_<task>_speed/CANDIDATE/ (VERIFY names that folder; WORKERS=2 for two runs at once).
set -e
cd "$(dirname "$0")/.."
usage="usage: speed_verification.sh ENV STUDY FIRST_SEED CANDIDATE"
env=${1:?$usage}
study=${2:?$usage}
first_seed=${3:?$usage}
name=${4:?$usage}
args=(--env "$env" --algos reinforce --config "reinforce=benchmarks/configs/$study/$name.yml"
    --seeds 10 --first-seed "$first_seed" --budget 1000000 --eval-freq 50000 --eval-episodes 5
    --out "benchmarks/results/${VERIFY:?VERIFY names the verification folder}/$name" --workers "${WORKERS:-1}" --no-progress)
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
