#!/usr/bin/env bash
# A chunk of the defaults study's runs on a lent machine with many cores (README.md beside this file, "State"):
# REINFORCE's three candidates on classic seeds 1 and 2, each (candidate, task, seed) a run of run.sh in its own folder
# under WORK, JOBS at a time, the longest first (the cost table's training rates). At STOP_AFTER seconds every run
# still going is stopped (SIGTERM: it keeps its last checkpoint), and the per_run/ files of every run (a finished
# run's summary, an unfinished run's evaluations and checkpoint) go into ARCHIVE, laid out as this folder is:
#   tar xzf ARCHIVE -C benchmarks/results/defaults_study
# then queue.sh here skips the finished runs, resumes the others and rebuilds each folder's tables.
#   JOBS=16 STOP_AFTER=520 WORK=/tmp/defaults ARCHIVE=$OUT/defaults_chunk.tgz bash device_chunk.sh
# Run from the repository root, with `sb3-reinforce` and `python` on PATH.
set -u
here=benchmarks/results/defaults_study
work=${WORK:-/tmp/defaults_chunk}
archive=${ARCHIVE:?ARCHIVE: the .tgz to write}
# Longest first: value20 makes a value step per short episode, LunarLander's evaluations are the longest.
order=(
    "value20 LunarLander-v3" "value20 LunarLanderContinuous-v3" "today LunarLanderContinuous-v3"
    "value20 Pendulum-v1" "value20 MountainCar-v0" "value20 Acrobot-v1" "today LunarLander-v3"
    "value20_2048 LunarLander-v3" "value20_2048 LunarLanderContinuous-v3" "value20_2048 Acrobot-v1"
    "today Acrobot-v1" "today Pendulum-v1" "value20_2048 Pendulum-v1" "today MountainCar-v0"
    "value20_2048 MountainCar-v0" "value20 CartPole-v1" "today CartPole-v1" "value20_2048 CartPole-v1"
)
jobs=()
for job in "${order[@]}"; do
    for seed in 1 2; do jobs+=("$job $seed"); done
done
mkdir -p "$work"
# One process group for every run, so that one signal stops them all (compare's Dask workers included).
printf '%s\n' "${jobs[@]}" | setsid xargs -P "${JOBS:-16}" -L 1 bash -c '
    FIRST_SEED=$2 SEEDS=1 OUT_ROOT='"$work"'/seed$2 bash '"$here"'/run.sh "$0" "$1" \
        > '"$work"'/"$0"_"$1"_seed$2.log 2>&1' &
group=$!
sleep 1  # till setsid has made the group
start=$SECONDS
while kill -0 -- "-$group" 2>/dev/null && [ $((SECONDS - start)) -lt "${STOP_AFTER:-520}" ]; do sleep 2; done
if kill -0 -- "-$group" 2>/dev/null; then
    echo "stopping the runs still going at $((SECONDS - start)) s"
    kill -TERM -- "-$group"
    for _ in $(seq 30); do kill -0 -- "-$group" 2>/dev/null || break; sleep 1; done
    kill -KILL -- "-$group" 2>/dev/null
fi
staged=$work/archive
rm -rf "$staged"
for folder in "$work"/seed*/*/*/per_run; do
    [ -d "$folder" ] || continue
    candidate_env=${folder%/per_run}
    candidate_env=${candidate_env#"$work"/seed*/}
    mkdir -p "$staged/$candidate_env/per_run"
    cp -a "$folder"/. "$staged/$candidate_env/per_run/"
done
mkdir -p "$staged/device_chunk_logs"
cp -a "$work"/*.log "$staged/device_chunk_logs/" 2>/dev/null
tar czf "$archive" -C "$staged" .
echo "finished runs: $(ls "$staged"/*/*/per_run/*_seed?.json 2>/dev/null | wc -l) of ${#jobs[@]}"
for log in "$work"/*.log; do grep -l -i -E "Traceback|error" "$log"; done | head -5
