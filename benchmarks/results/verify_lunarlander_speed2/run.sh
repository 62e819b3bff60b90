#!/usr/bin/env bash
# Issue 64: the pick of LunarLander-v3 speed study 2 (../lunarlander_speed2/, its rule 3) verified as the entry was
# (../verify_lunarlander_gamma0995/: 10 fresh seeds, 1M steps, 5 deterministic episodes every 50k steps), on fresh
# seeds 1030-1039. README.md beside this file. Resumable. Run from an activated venv.
#   run.sh CANDIDATE      a config of benchmarks/configs/lunarlander_speed2/ (WORKERS=2 for two runs at once)
VERIFY=verify_lunarlander_speed2 exec bash "$(dirname "$0")/../../speed_verification.sh" LunarLander-v3 lunarlander_speed2 \
    1030 "${1:?usage: run.sh CANDIDATE}"
