#!/usr/bin/env bash
# One chunk of CarRacing-v3 runs (issue #35) on a lent GPU machine (16 CPU cores, one H100, offline): the runs no
# decision of the tuning study waits on -- a_entry on tuning seeds 102-103 (stage 2 runs a_entry whatever d_lin_lr
# scores) and PPO's zoo entry on fresh seeds 5000-5002 (the verification's PPO row) -- with the repository's own
# commands and DEVICE=cuda, stopped with SIGTERM after RUN_S seconds; compare keeps each run's last evaluation's
# checkpoint, which the project's machines resume from. First, the GPU test of resuming on another device.
# Dependencies travel as wheels in .whl/ (ignored by git; README.md here). From the repository root:
#   OUT=/some/folder bash benchmarks/results/device_chunk/device_chunk.sh
set -u
RUN_S=${RUN_S:-510}
OUT=${OUT:-/tmp/device_out}
mkdir -p "$OUT" /tmp/bin /tmp/logs
export PYTHONUNBUFFERED=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl || exit 3
tar xJf .whl/envpool_slim_cp312.tar.xz -C /tmp/site || exit 3
export PYTHONPATH=/tmp/site:$PWD
printf '#!/bin/sh\nexec python3 -m sb3_reinforce.lab.cli "$@"\n' > /tmp/bin/sb3-reinforce && chmod +x /tmp/bin/sb3-reinforce
export PATH=/tmp/bin:$PATH
python3 -c "import envpool, torch, rl_zoo3.wrappers, sb3_reinforce.lab.compare.command, Box2D, pygame, distributed
import gymnasium.envs.box2d.car_racing
envpool.make_gymnasium('CarRacing-v3', num_envs=1)
print('imports ok, torch', torch.__version__, 'cuda', torch.cuda.is_available())" || exit 4
nproc --all; nvidia-smi -L 2>/dev/null; date -u
export DEVICE=${DEVICE:-cuda}
for seed in 102 103; do
    timeout -k 45 -s TERM "$RUN_S" bash benchmarks/results/carracing_tuning/run.sh a_entry "$seed" envpool \
        > "/tmp/logs/a_entry_$seed.log" 2>&1 &
done
WORKERS=3 timeout -k 45 -s TERM "$RUN_S" bash benchmarks/results/verify_carracing_tuned/run.sh ppo \
    > /tmp/logs/ppo.log 2>&1 &
timeout 240 python3 -m pytest -p no:cacheprovider -q tests/test_compare_resume.py -k another_device \
    > /tmp/logs/pytest_device.log 2>&1
tail -3 /tmp/logs/pytest_device.log
uptime; nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv 2>/dev/null
wait; date -u; uptime
for seed in 102 103; do
    tar cf "$OUT/a_entry_$seed.tar" benchmarks/results/carracing_tuning/a_entry/per_run/*seed"$seed"*
done
for seed in 5000 5001 5002; do
    tar cf "$OUT/ppo_$seed.tar" benchmarks/results/verify_carracing_tuned/per_run/ppo_seed"$seed"*
done
tar czf "$OUT/logs.tgz" -C /tmp/logs .
grep -h -v -E "Warning|warn\(|pkg_resources" /tmp/logs/*.log | tail -40
ls -la "$OUT"
