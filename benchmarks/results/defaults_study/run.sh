#!/usr/bin/env bash
# Issue 62's defaults study (README.md beside this file): one candidate's runs on the suite, resumable.
#   run.sh CANDIDATE [ENV ...]     CANDIDATE: today, value20, value20_2048, ppo or a2c; ENVs: default the whole suite
# Each candidate is a zoo file with only a `default` entry (benchmarks/configs/defaults_study/CANDIDATE.yml): the
# algorithm as ALGO("MlpPolicy", env) builds it, one env, no wrappers. Seeds 0-2 (FIRST_SEED, SEEDS to choose), 10
# deterministic and 10 sampled-action episodes every 5% of the budget; one run at a time unless WORKERS=2.
# Runs go to benchmarks/results/defaults_study/CANDIDATE/ENV/ (OUT_ROOT/CANDIDATE/ENV/ with OUT_ROOT set: device_chunk.sh).
# Run from the repository root, venv activated.
set -e
cd "$(dirname "$0")/../../.."
candidate=${1:?usage: run.sh today|value20|value20_2048|ppo|a2c [ENV ...]}
shift
case $candidate in ppo | a2c) algo=$candidate ;; *) algo=reinforce ;; esac
config=benchmarks/configs/defaults_study/$candidate.yml
[ -f "$config" ] || { echo "no $config" >&2; exit 2; }
classic=(CartPole-v1 Acrobot-v1 MountainCar-v0 Pendulum-v1 LunarLander-v3 LunarLanderContinuous-v3)
mapfile -t mujoco < <(python benchmarks/mujoco_thresholds.py --source "Tianshou REINFORCE")   # "ENV THRESHOLD" lines
envs=("$@")
[ ${#envs[@]} -gt 0 ] || envs=("${classic[@]}" "${mujoco[@]%% *}")
for env in "${envs[@]}"; do
    budget=1000000
    [ "$env" = CartPole-v1 ] && budget=100000
    threshold=()
    for line in "${mujoco[@]}"; do [ "${line%% *}" = "$env" ] && threshold=(--threshold "${line##* }"); done
    out=${OUT_ROOT:-benchmarks/results/defaults_study}/$candidate/$env
    first=${FIRST_SEED:-0} seeds=${SEEDS:-3} finished=0
    for ((seed = first; seed < first + seeds; seed++)); do [ -f "$out/per_run/${algo}_seed$seed.json" ] && ((++finished)); done
    if [ "$finished" = "$seeds" ]; then  # compare would only redraw its report: skip it (a restart then costs seconds)
        echo "$out: seeds $first-$((first + seeds - 1)) finished, skipped"
        continue
    fi
    args=(--env "$env" --algos "$algo" --config "$algo=$config" --seeds "$seeds" --first-seed "$first"
        --budget "$budget" --eval-freq $((budget / 20)) --eval-episodes 10 "${threshold[@]}"
        --out "$out" --workers "${WORKERS:-1}" --no-progress)
    echo "\$ sb3-reinforce compare ${args[*]}"
    sb3-reinforce compare "${args[@]}"
done
