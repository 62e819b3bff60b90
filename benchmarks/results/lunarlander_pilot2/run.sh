#!/bin/bash
# The pilot: each config trains seed 1 for 400k steps, evaluated as the 1M comparisons (5 episodes every 50k
# steps, deterministic and stochastic); two at a time on the 2 cores.
cd "$(git rev-parse --show-toplevel)"
P=benchmarks/results/lunarlander_pilot2
run() { sb3-reinforce compare --env LunarLander-v3 --algos reinforce --seeds 1 --first-seed 1 --budget 400000 \
    --eval-freq 50000 --workers 1 --no-progress --reinforce-config $P/$1.yml --out $P/$1 > $P/$1.log 2>&1; }
run D & run E & wait
run F & run G & wait
