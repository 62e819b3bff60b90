#!/usr/bin/env bash
# Issue 64's wall-clock benchmark (README.md beside this file): one repeat, resumable.
#   run.sh repeat1 | repeat2 [ENV ...]
# Each env's REINFORCE, PPO and A2C zoo entries (REINFORCE and PPO on MuJoCo) on seeds 7000-7002, one run at a time
# in seed-major order (reinforce, ppo, a2c on 7000, then 7001, ...), so that the algorithms share the machine's load;
# each algorithm its own zoo budget, evaluated as the results table evaluates (5 deterministic episodes every
# budget/20 steps), each run stopped at its first evaluation at or above the threshold. Pause every background run
# first (SIGSTOP its process group). Then: python benchmarks/wallclock_table.py. Run from the repository root.
# A speed study's pick in REINFORCE's place (the study's rule 3):
#   CANDIDATE=NAME CANDIDATE_CONFIG=FILE run.sh repeat1 ENV ...
# trains REINFORCE from that zoo file (compare's --config) beside the same PPO and A2C entries, into
# candidates/NAME/REPEAT/ENV/ (then: python benchmarks/wallclock_table.py --root benchmarks/results/wallclock/candidates/NAME).
# ALGOS=reinforce,ppo run.sh ...: those algorithms only (LunarLanderContinuous-v3: A2C's zoo budget there is 5M steps,
# about 1.5 hours a repeat on its own, and in 1M steps it reached 200 on none of 5 seeds: ../verify_llc; README.md here).
set -e
cd "$(dirname "$0")/../../.."
repeat=${1:?usage: run.sh repeat1 | repeat2 [ENV ...]}
shift
out=benchmarks/results/wallclock
config=()
if [ -n "${CANDIDATE:-}" ]; then
    out=$out/candidates/$CANDIDATE
    config=(--config "reinforce=${CANDIDATE_CONFIG:?CANDIDATE needs CANDIDATE_CONFIG: a zoo file}")
fi
classic=(CartPole-v1 Acrobot-v1 MountainCar-v0 Pendulum-v1 LunarLander-v3 LunarLanderContinuous-v3)
mapfile -t mujoco < <(python benchmarks/mujoco_thresholds.py --source "Tianshou REINFORCE" HalfCheetah-v4 Hopper-v4)
envs=("$@")
[ ${#envs[@]} -gt 0 ] || envs=("${classic[@]}" "${mujoco[@]%% *}")
for env in "${envs[@]}"; do
    algos=${ALGOS:-reinforce,ppo,a2c}
    threshold=()
    for line in "${mujoco[@]}"; do
        [ "${line%% *}" = "$env" ] && { algos=reinforce,ppo; threshold=(--threshold "${line##* }"); }
    done
    args=(--env "$env" --algos "$algos" "${config[@]}" --seeds 3 --first-seed 7000 --budget zoo --eval-episodes 5 "${threshold[@]}"
        --stop-at-threshold --out "$out/$repeat/$env" --workers 1 --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
done
