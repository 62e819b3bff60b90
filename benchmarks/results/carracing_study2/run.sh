#!/usr/bin/env bash
# CarRacing-v3 study 2 (README.md beside this file): one config on one tuning seed, 1M steps, resumable, as the first
# tuning study ran its configs. Usage: run.sh CONFIG SEED [VEC_ENV]. Run from an activated venv.
STUDY=carracing_study2 exec bash "$(dirname "$0")/../carracing_tuning/run.sh" "$@"
