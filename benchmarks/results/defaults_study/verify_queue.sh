#!/usr/bin/env bash
# The defaults study's verification on fresh seeds (README.md beside this file, "Verification on fresh seeds"),
# resumable: step 2's pick (read off the tuning runs: it fails while they are unfinished), PPO's defaults and today's,
# the classic tasks seed by seed on 9000-9002, then the MuJoCo tasks on seed 9000, into verify/CANDIDATE/ENV/.
# `python benchmarks/defaults_table.py --verification` tabulates them. Run from the repository root, venv activated.
set -e
here=$(dirname "$0")
pick=$(python benchmarks/defaults_table.py --pick)
export OUT_ROOT=benchmarks/results/defaults_study/verify
classic=(CartPole-v1 Acrobot-v1 MountainCar-v0 Pendulum-v1 LunarLander-v3 LunarLanderContinuous-v3)
mujoco=(HalfCheetah-v4 Hopper-v4 Walker2d-v4 Ant-v4 Humanoid-v4 Swimmer-v4 Reacher-v4 InvertedPendulum-v4
    InvertedDoublePendulum-v4)
for seed in 9000 9001 9002; do
    for candidate in "$pick" ppo today; do
        FIRST_SEED=$seed SEEDS=1 bash "$here/run.sh" "$candidate" "${classic[@]}"
    done
done
for candidate in "$pick" ppo today; do
    FIRST_SEED=9000 SEEDS=1 bash "$here/run.sh" "$candidate" "${mujoco[@]}"
done
