#!/usr/bin/env bash
# The study's command, two workers (one per core) on one journal storage; run again to resume.
# After a stop (workers killed mid-trial): bash run.sh --rerun-interrupted (the first worker queues the interrupted
# trials again; they go on in their folders, finished seeds kept).
cd "$(dirname "$0")/../../.." || exit 1
D=benchmarks/results/study_lunarlander_1m
cmd=(python benchmarks/tune.py --env LunarLander-v3 --base-config benchmarks/configs/reinforce_lunarlander_lin.yml
     --study-dir $D --study-name reinforce-lunarlander-1m --seeds 100 101 --max-trials 30
     --fixed $D/fixed.yml --enqueue $D/enqueue.yml $D/enqueue2.yml)
"${cmd[@]}" "$@" >> $D/worker0.log 2>&1 &
sleep 20
"${cmd[@]}" >> $D/worker1.log 2>&1 &
wait
