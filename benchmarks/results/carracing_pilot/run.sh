#!/usr/bin/env bash
# CarRacing-v3 pilot (issue #13). Usage: run.sh FIRST_SEED SEEDS CONFIG... (see benchmarks/run_pilot.sh)
exec "$(dirname "$0")/../../run_pilot.sh" CarRacing-v3 carracing_pilot "$@"
