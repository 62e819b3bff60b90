#!/usr/bin/env bash
# CarRacing-v3 at its zoo entry's own budget (issue 63): REINFORCE's zoo entry and PPO's on fresh seeds 6000-6002,
# 4M steps each (README.md beside this file). Usage:
#   run.sh reinforce
#   run.sh ppo
# Training environments on EnvPool (VEC_ENV=subproc or dummy to change), every evaluation on Gymnasium's
# CarRacing-v3 (5 deterministic and 5 sampled-action episodes every 100k steps); networks on the CPU (DEVICE=cuda
# for a GPU). One core per run (WORKERS=2 for two runs at once). Resumable: finished runs are skipped, interrupted
# ones continue from their last evaluation's checkpoint; several commands may share the folder (each writes its own
# runs). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
algo=${1:?usage: run.sh reinforce | run.sh ppo}
args=(--env CarRacing-v3 --algos "$algo" --seeds 3 --first-seed 6000 --budget 4000000 --eval-freq 100000
    --eval-episodes 5 --threshold 500 --out benchmarks/results/verify_carracing_4m --workers "${WORKERS:-1}"
    --vec-env "${VEC_ENV:-envpool}" --device "${DEVICE:-cpu}" --no-progress)
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
