#!/usr/bin/env bash
# The shipped REINFORCE agents (rl-trained-agents/reinforce/<env>_1/): each env's zoo entry
# (zoo_configs/reinforce.yml) trained with `sb3-reinforce-zoo train` on seed 0 at the entry's own budget
# (n_timesteps), with the zoo's evaluation callback (10 deterministic episodes every 50,000 steps, which
# also saves best_model.zip). Usage: train.sh OUT ENV [ENV ...] (from the repository root, venv active).
# Each env's run goes to OUT/reinforce/<env>_1/; copy.sh then takes what enjoy needs into rl-trained-agents/.
set -euo pipefail
# one torch thread per run (several runs share the cores; two threads each made all of them several times slower)
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
out=$1
shift
for env in "$@"; do
    if [ -f "$out/reinforce/${env}_1/${env}.zip" ]; then echo "$env: done already"; continue; fi
    echo "\$ sb3-reinforce-zoo train --algo reinforce --env $env --seed 0 -f $out --eval-freq 50000 --eval-episodes 10 --n-eval-envs 1 --vec-env dummy"
    sb3-reinforce-zoo train --algo reinforce --env "$env" --seed 0 -f "$out" --eval-freq 50000 --eval-episodes 10 \
        --n-eval-envs 1 --vec-env dummy
done
