#!/usr/bin/env bash
# Verification of the LunarLander-v3 re-scoring's round-2 pick (gamma 0.995) on fresh seeds 3000-3009, REINFORCE
# only: PPO and A2C ran with the same protocol on seeds 2000-2004 in ../verify_lunarlander_normobs/. Resumable
# (finished runs are skipped, interrupted ones continue from their last evaluation). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
exec sb3-reinforce compare --env LunarLander-v3 --algos reinforce --seeds 10 --first-seed 3000 --budget ppo \
    --reinforce-config benchmarks/configs/reinforce_lunarlander_value20_clip_normobs_gamma0995.yml \
    --out benchmarks/results/verify_lunarlander_gamma0995 --workers 2 --no-progress
