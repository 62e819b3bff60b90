#!/usr/bin/env bash
# CarRacing-v3 study 2's stage 1 (README.md beside this file), resumable: one run at a time; finished runs are skipped,
# interrupted ones continue from their last checkpoint. c_clip05 and d_e8 on seeds 100 and 101 first, b_std005 on
# seed 101 last: its seed 100 scored 82.8, and a config's score is its lowest seed's, so that run can change the
# two best only if c_clip05 or d_e8 scores below 92.8, within the rule's tie margin of it (README.md, State). Stage 2's runs are named by the rule once
# stage 1 is decided (python benchmarks/carracing_tuning.py --study carracing_study2).
set -e
for seed in 100 101; do
    for config in c_clip05 d_e8; do
        bash "$(dirname "$0")/run.sh" "$config" "$seed"
    done
done
bash "$(dirname "$0")/run.sh" b_std005 101
