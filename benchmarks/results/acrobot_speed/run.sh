#!/usr/bin/env bash
# Issue 64's Acrobot-v1 speed study (README.md beside this file), resumable.
#   run.sh [CANDIDATE ...]     default: entry v10 e2 e2_v10 e4
[ $# -gt 0 ] || set -- entry v10 e2 e2_v10 e4
exec bash "$(dirname "$0")/../../speed_study.sh" Acrobot-v1 acrobot_speed "$@"
