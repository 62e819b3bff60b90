#!/usr/bin/env bash
# Verification of the CarRacing-v3 tuning study's pick (../carracing_tuning/) on fresh seeds 5000-5002 at 1M steps,
# and PPO's zoo entry at the same budget on the same seeds (README.md beside this file). Usage:
#   run.sh reinforce CONFIG   (CONFIG: the pick, a name in benchmarks/configs/carracing_tuning/)
#   run.sh ppo
# Training environments on EnvPool (VEC_ENV=subproc or dummy to change), evaluations on Gymnasium's CarRacing-v3;
# networks on the CPU (DEVICE=cuda for a GPU).
# One core per run by default (WORKERS=2 for two runs at once). Resumable: finished runs are skipped, interrupted
# ones continue from their last evaluation's checkpoint; several commands may share the folder (each writes its
# own runs). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
algo=${1:?usage: run.sh reinforce CONFIG | run.sh ppo}
args=(--env CarRacing-v3 --algos "$algo" --seeds 3 --first-seed 5000 --budget 1000000 --threshold 500
    --out benchmarks/results/verify_carracing_tuned --workers "${WORKERS:-1}" --vec-env "${VEC_ENV:-envpool}"
    --device "${DEVICE:-cpu}" --no-progress)
if [ "$algo" = reinforce ]; then
    config=${2:?usage: run.sh reinforce CONFIG (the pick of the tuning study)}
    args+=(--reinforce-config "benchmarks/configs/carracing_tuning/$config.yml")
fi
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
