#!/usr/bin/env bash
# The MuJoCo table of docs/results.md in one command (issue 45): REINFORCE's zoo entry (zoo_configs/reinforce.yml)
# on each env of the published table (benchmarks/published/reinforce_mujoco.csv), 10 fresh seeds (1000-1009), 3M
# steps, evaluation every 50k steps of 10 deterministic and 10 sampled episodes, then the tables with the published
# numbers beside them (docs/results.md's, its figure, and PPO's beside rl-baselines3-zoo's). Resumable:
# run it again after a stop (finished runs are kept, unfinished ones resume).
#
#   bash benchmarks/mujoco_table.sh                                # on this machine, one env after the other
#   bash benchmarks/mujoco_table.sh --scheduler tcp://HOST:8786    # on a Dask cluster: all envs' runs at once
#   ENVS="HalfCheetah-v4 Hopper-v4" bash benchmarks/mujoco_table.sh  # some envs only (the table keeps the others')
#   PPO_ENVS="" bash benchmarks/mujoco_table.sh                     # without PPO's runs
#
# PPO beside it (issue 45, item 4): on each env of PPO_ENVS that is selected (default: the envs rl-baselines3-zoo
# publishes a PPO score for, benchmarks/published/ppo_zoo_mujoco.csv), rl_zoo3's PPO entry on seeds 1000-1002 at its
# own zoo budget, same evaluation, into the same folder (the learning curves then show both; the published table
# reads REINFORCE's runs only).
#
# Each env's folder is benchmarks/results/verify_mujoco/ENV/; its solve threshold (the "steps to reach" column) is
# the higher published number at 3M. Run from the repository's root with the compare and mujoco extras installed.
set -euo pipefail
cd "$(dirname "$0")/.."
published=benchmarks/published/reinforce_mujoco.csv
extra=("$@")
# env -> the higher published number at 3M (Tianshou's REINFORCE, Spinning Up's VPG), read off the CSV
thresholds=$(python benchmarks/mujoco_thresholds.py)   # set -e stops here if the table cannot be read
mapfile -t targets <<<"$thresholds"
ppo_published=benchmarks/published/ppo_zoo_mujoco.csv
ppo_envs=" ${PPO_ENVS-$(tail -n +2 "$ppo_published" | cut -d, -f1 | tr '\n' ' ')} "
run_env() {
    sb3-reinforce compare --env "$1" --algos reinforce --seeds 10 --first-seed 1000 --budget 3000000 \
        --eval-freq 50000 --eval-episodes 10 --threshold "$2" --no-progress \
        --out "benchmarks/results/verify_mujoco/$1" "${extra[@]}"
    if [[ "$ppo_envs" == *" $1 "* ]]; then
        sb3-reinforce compare --env "$1" --algos ppo --seeds 3 --first-seed 1000 --budget zoo \
            --eval-freq 50000 --eval-episodes 10 --threshold "$2" --no-progress \
            --out "benchmarks/results/verify_mujoco/$1" "${extra[@]}"
    fi
}
pids=()
for line in "${targets[@]}"; do
    read -r env_id threshold <<<"$line"
    if [ -n "${ENVS:-}" ] && [[ " $ENVS " != *" $env_id "* ]]; then continue; fi
    if [[ " ${extra[*]} " == *" --scheduler"* ]]; then
        run_env "$env_id" "$threshold" & pids+=($!)   # a cluster schedules every env's runs as its CPUs free up
    else
        run_env "$env_id" "$threshold"
    fi
done
for pid in "${pids[@]}"; do wait "$pid"; done
mapfile -t folders < <(find benchmarks/results/verify_mujoco -mindepth 2 -maxdepth 2 -name results.csv -printf '%h\n' | sort)
# every table and figure the results page shows, from the committed runs (tests/test_docs.py checks them)
sb3-reinforce report "${folders[@]}" --published "$published" --published-into docs/results.md --figure docs/images/mujoco.png
sb3-reinforce report "${folders[@]}" --published "$ppo_published" --published-algo ppo \
    --published-into docs/results.md
