#!/usr/bin/env bash
# Acrobot-v1 pilot (issue #13). Usage: run.sh FIRST_SEED SEEDS CONFIG... (see benchmarks/run_pilot.sh)
exec "$(dirname "$0")/../../run_pilot.sh" Acrobot-v1 acrobot_pilot "$@"
