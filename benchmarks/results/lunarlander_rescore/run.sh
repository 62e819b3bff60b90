#!/usr/bin/env bash
# LunarLander-v3 re-scoring (issue #13, session 9): the study's three best trials on four more tuning seeds
# (102-105), two new candidates on all six tuning seeds (100-105); 1M steps, 2 runs at a time. Run again to
# resume (finished runs are skipped, interrupted ones resume from their last evaluation).
cd "$(dirname "$0")/../../.." || exit 1
C=benchmarks/configs/lunarlander_rescore
R=benchmarks/results/lunarlander_rescore
run() {  # CONFIG FIRST_SEED SEEDS
    args=(--env LunarLander-v3 --algos reinforce --seeds "$3" --first-seed "$2" --budget 1000000
        --reinforce-config "$C/$1.yml" --out "$R/$1" --workers 2 --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
}
run t7_value20_clip 102 4
run t1_value20 102 4
run t5_value80 102 4
run a_clip_lin5e-3 100 6
run b_clip_normobs 100 6
