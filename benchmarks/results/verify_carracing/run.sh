#!/usr/bin/env bash
# Verification of CarRacing-v3's zoo entry (the pilot's config b_value20) on fresh seeds 4000-4002 at 1M steps,
# as the rule fixed before the pilot's last evaluations (commit f456d67, benchmarks/results/carracing_pilot/README.md)
# asks. Usage: run.sh [ALGO] (reinforce by default; ppo runs PPO's zoo entry at the same 1M budget on the same
# seeds). The threshold is issue #13's 500 (Gymnasium's, compare's default, is 900). Resumable: finished runs
# are skipped and interrupted ones continue from their last evaluation's checkpoint. Run from an activated venv;
# 4.3 to 7.5 hours of a core per 1M-step run here. WORKERS=1 run.sh ppo runs PPO on the core left free while
# the last REINFORCE run finishes (compare's folder takes several commands at once: each writes only its own runs);
# VEC_ENV=subproc run.sh steps each run's 4 environments in processes of their own (one run on both cores).
cd "$(dirname "$0")/../../.." || exit 1
algo=${1:-reinforce}
args=(--env CarRacing-v3 --algos "$algo" --seeds 3 --first-seed 4000 --budget 1000000
    --threshold 500 --out benchmarks/results/verify_carracing --workers "${WORKERS:-2}" --vec-env "${VEC_ENV:-dummy}"
    --no-progress)
if [ "$algo" = reinforce ]; then args+=(--reinforce-config benchmarks/configs/carracing_pilot/b_value20.yml); fi
echo "\$ sb3-reinforce compare ${args[*]}"
exec sb3-reinforce compare "${args[@]}"
