#!/usr/bin/env bash
# The defaults study's cost, measured before its runs are scheduled (README.md beside this file): each candidate's
# training steps/s on each task (10,240 steps from tuning seed 100, built as compare builds it, one torch thread) and
# 10 deterministic evaluation episodes, rows in cost.csv with the load average at each start. Background runs are
# paused (SIGSTOP of their process group, PAUSE_PGID) for each group of measurements, at most a few minutes at a time,
# then resumed. TAG=pair with two commands at once for the side-by-side figures. Run from the repository root.
cd "$(dirname "$0")/../../.." || exit 1
groups=("CartPole-v1 Acrobot-v1 MountainCar-v0 Pendulum-v1 LunarLander-v3 LunarLanderContinuous-v3"
    "HalfCheetah-v4 Hopper-v4 Walker2d-v4 Ant-v4 Humanoid-v4"
    "Swimmer-v4 Reacher-v4 InvertedPendulum-v4 InvertedDoublePendulum-v4")
for candidate in ${CANDIDATES:-today value20 value20_2048 ppo a2c}; do
    case $candidate in ppo | a2c) algo=$candidate ;; *) algo=reinforce ;; esac
    for group in "${groups[@]}"; do
        [ -n "$PAUSE_PGID" ] && kill -STOP -- "-$PAUSE_PGID"
        # shellcheck disable=SC2086
        python benchmarks/mujoco_cost.py run --algo "$algo" --envs $group --steps 10240 --seed 100 \
            --config "benchmarks/configs/defaults_study/$candidate.yml" --tag "${TAG:-alone}" \
            --out benchmarks/results/defaults_study/cost.csv
        [ -n "$PAUSE_PGID" ] && { kill -CONT -- "-$PAUSE_PGID"; sleep "${RESUME_S:-60}"; }
    done
done
