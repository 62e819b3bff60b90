#!/usr/bin/env bash
# Issue 64's second LunarLander-v3 speed study (README.md beside this file), resumable: the candidates on tuning seeds
# 100-103, then candidates and the entry on 104-107 (the entry's runs on 100-103 are the first study's,
# ../lunarlander_speed/entry/), seed-major, one run at a time.
#   run.sh             the whole study
set -e
here=$(dirname "$0")
SEEDS="100 101 102 103" bash "$here/../../speed_study.sh" LunarLander-v3 lunarlander_speed2 e4_ent001 e4_lr5e-3 e2
SEEDS="104 105 106 107" bash "$here/../../speed_study.sh" LunarLander-v3 lunarlander_speed2 e4_ent001 e4_lr5e-3 e2 entry
