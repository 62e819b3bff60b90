#!/usr/bin/env bash
# LunarLander-v3's zoo entry trained on EnvPool (--vec-env envpool), evaluated on Gymnasium's env, fresh seeds
# 7000-7009, 1M steps (README.md beside this file has the rule). Resumable. Run from an activated venv with the
# envpool extra; WORKERS runs at a time (2 by default).
cd "$(dirname "$0")/../../.." || exit 1
args=(--env LunarLander-v3 --algos reinforce --seeds 10 --first-seed 7000 --budget 1000000 --threshold 200
    --out benchmarks/results/verify_lunarlander_envpool --workers "${WORKERS:-2}" --vec-env envpool --no-progress)
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
