#!/usr/bin/env bash
# CarRacing-v3 study 2's stage 1 (README.md beside this file), resumable: each candidate on seed 100, then on 101,
# one run at a time; finished runs are skipped, interrupted ones continue from their last checkpoint. Stage 2's runs
# are named by the rule once stage 1 is decided (python benchmarks/carracing_tuning.py --study carracing_study2).
set -e
for seed in 100 101; do
    for config in b_std005 c_clip05 d_e8; do
        bash "$(dirname "$0")/run.sh" "$config" "$seed"
    done
done
