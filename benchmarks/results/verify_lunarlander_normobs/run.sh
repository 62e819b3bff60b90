#!/usr/bin/env bash
# Verification of the LunarLander-v3 re-scoring's pick on fresh seeds 2000-2009 (REINFORCE), with PPO and A2C on
# 2000-2004; resumable (finished runs are skipped). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
V=benchmarks/results/verify_lunarlander_normobs
for algo in reinforce ppo a2c; do
    seeds=5; [ "$algo" = reinforce ] && seeds=10
    args=(--env LunarLander-v3 --algos "$algo" --seeds "$seeds" --first-seed 2000 --budget ppo
        --reinforce-config benchmarks/configs/reinforce_lunarlander_value20_clip_normobs.yml --out "$V" --workers 2 --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
done
