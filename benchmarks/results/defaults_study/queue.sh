#!/usr/bin/env bash
# The defaults study's runs in the order that decides soonest (README.md beside this file), resumable: run again,
# finished runs are skipped. Classic tasks seed by seed (REINFORCE's candidates and PPO, which the rule compares),
# then the MuJoCo tasks on seed 0, then the verification on fresh seeds, then A2C (reported, not in the rule).
# Run from the repository root.
set -e
here=$(dirname "$0")
classic=(CartPole-v1 Acrobot-v1 MountainCar-v0 Pendulum-v1 LunarLander-v3 LunarLanderContinuous-v3)
mujoco=(HalfCheetah-v4 Hopper-v4 Walker2d-v4 Ant-v4 Humanoid-v4 Swimmer-v4 Reacher-v4 InvertedPendulum-v4
    InvertedDoublePendulum-v4)
for seed in 0 1 2; do
    for candidate in today value20 value20_2048 ppo; do
        FIRST_SEED=$seed SEEDS=1 bash "$here/run.sh" "$candidate" "${classic[@]}"
    done
done
for candidate in today value20 value20_2048 ppo; do
    FIRST_SEED=0 SEEDS=1 bash "$here/run.sh" "$candidate" "${mujoco[@]}"
done
# then the pick on fresh seeds beside PPO and today (rule 4), before A2C, which the rule does not read
bash "$here/verify_queue.sh"
FIRST_SEED=0 SEEDS=3 bash "$here/run.sh" a2c "${classic[@]}"
FIRST_SEED=0 SEEDS=1 bash "$here/run.sh" a2c "${mujoco[@]}"
