#!/usr/bin/env bash
# Every run of the study's stage 1 (README.md beside this file), in its order: env by env (the two envs PPO is
# compared on first, the most expensive last), the three candidates on each. Resumable: run it again after a stop.
# Its log goes to stdout; started in the background from a worktree's activated venv:
#   nohup nice -n 10 bash benchmarks/results/mujoco_tuning/run_all.sh >> benchmarks/results/mujoco_tuning/run_all.log 2>&1 &
cd "$(dirname "$0")" || exit 1
for env_id in HalfCheetah-v4 Hopper-v4 Walker2d-v4 Swimmer-v4 InvertedPendulum-v4 InvertedDoublePendulum-v4 Reacher-v4 \
    Ant-v4 Humanoid-v4; do
    for config in a_value4 b_value4_lr3 c_value8; do
        echo "== $(date -u +%FT%TZ) $config $env_id"
        bash run.sh "$config" "$env_id" || { status=$?; echo "== stopped ($status)"; exit "$status"; }
    done
done
echo "== $(date -u +%FT%TZ) stage 1 done"
