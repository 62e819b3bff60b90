#!/usr/bin/env bash
# Issue 64's LunarLander-v3 speed study (README.md beside this file), resumable.
#   run.sh [CANDIDATE ...]     default: entry e4 e8 e8_lr5e-3
[ $# -gt 0 ] || set -- entry e4 e8 e8_lr5e-3
exec bash "$(dirname "$0")/../../speed_study.sh" LunarLander-v3 lunarlander_speed "$@"
