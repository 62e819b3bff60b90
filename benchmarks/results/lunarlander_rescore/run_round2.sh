#!/usr/bin/env bash
# LunarLander-v3 re-scoring, round 2 (issue #13, session 10): the round-1 pick (b_clip_normobs) with gamma 0.999
# and 0.995, on the six tuning seeds 100-105; 1M steps, 2 runs at a time. Run again to resume (finished runs are
# skipped, interrupted ones resume from their last evaluation). Run from an activated venv.
cd "$(dirname "$0")/../../.." || exit 1
C=benchmarks/configs/lunarlander_rescore
R=benchmarks/results/lunarlander_rescore
for config in c_normobs_gamma0999 d_normobs_gamma0995; do
    args=(--env LunarLander-v3 --algos reinforce --seeds 6 --first-seed 100 --budget 1000000
        --reinforce-config "$C/$config.yml" --out "$R/$config" --workers 2 --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
done
