#!/usr/bin/env bash
# Issue 64: the pick of the Acrobot-v1 speed study (../acrobot_speed2/, its rule 3) verified as the entry was
# (../verify_acrobot/: 10 fresh seeds, 1M steps, 5 deterministic episodes every 50k steps), on fresh seeds 1010-1019.
# README.md beside this file. Resumable. Run from an activated venv.
#   run.sh CANDIDATE      a config of benchmarks/configs/acrobot_speed2/ (WORKERS=2 for two runs at once)
VERIFY=verify_acrobot_speed exec bash "$(dirname "$0")/../../speed_verification.sh" Acrobot-v1 acrobot_speed2 1010 \
    "${1:?usage: run.sh CANDIDATE}"
