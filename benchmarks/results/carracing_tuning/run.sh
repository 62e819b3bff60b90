#!/usr/bin/env bash
# CarRacing-v3 tuning (README.md beside this file): one config on one tuning seed, 1M steps, resumable (a run
# continues from its last evaluation's checkpoint). Usage: run.sh CONFIG SEED [VEC_ENV] (VEC_ENV: envpool by
# default, or dummy / subproc). DEVICE=cuda trains the networks on a GPU (default: cpu). STUDY=carracing_study2 runs
# that study's configs into its folder instead (../carracing_study2/run.sh does). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
study=${STUDY:-carracing_tuning}
config=$1
seed=$2
vec_env=${3:-envpool}
args=(--env CarRacing-v3 --algos reinforce --seeds 1 --first-seed "$seed" --budget 1000000 --threshold 500
    --out "benchmarks/results/$study/$config" --workers 1 --vec-env "$vec_env" --no-progress
    --device "${DEVICE:-cpu}" --reinforce-config "benchmarks/configs/$study/$config.yml")
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
