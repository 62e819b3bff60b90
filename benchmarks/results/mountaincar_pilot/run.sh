#!/usr/bin/env bash
# MountainCar-v0 pilot (issue #13). Usage: run.sh FIRST_SEED SEEDS CONFIG... (see benchmarks/run_pilot.sh)
exec "$(dirname "$0")/../../run_pilot.sh" MountainCar-v0 mountaincar_pilot "$@"
