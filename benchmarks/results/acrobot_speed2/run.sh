#!/usr/bin/env bash
# Issue 64's second Acrobot-v1 speed study (README.md beside this file), resumable.
#   run.sh [CANDIDATE ...]     default: e2_loo e4_loo e8_loo
[ $# -gt 0 ] || set -- e2_loo e4_loo e8_loo
exec bash "$(dirname "$0")/../../speed_study.sh" Acrobot-v1 acrobot_speed2 "$@"
