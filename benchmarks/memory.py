"""
Peak resident memory of training runs, each in its own fresh process.

REINFORCE's rollout buffer holds one batch of whole episodes and is reused from batch to batch, so the peak
memory of a long run must equal that of a short one. This script trains ``REINFORCE`` (or SB3's ``PPO`` for
comparison) for a number of steps in a child process, and reads that process's peak resident set size
(``ru_maxrss``, or the resident size after training where that is higher: the kernel's high-water mark can lag
it slightly) and its resident size after training. One row per run goes to ``benchmarks/results/memory.csv``.

Usage::

    python benchmarks/memory.py                                   # reinforce 100k and 1M, ppo 100k
    python benchmarks/memory.py --runs reinforce:2000 ppo:2048    # seconds
    python benchmarks/memory.py --runs random:100000 random:1000000   # the environment alone, random actions

REINFORCE runs with :class:`~sb3_reinforce.safeguards.TrimHeap` (as ``sb3-reinforce compare`` and the zoo train it);
``reinforce_notrim`` is the same run without it.
"""

import argparse
import csv
import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).parent / "results" / "memory.csv"
DEFAULT_RUNS = ["reinforce:100000", "reinforce:1000000", "ppo:100000"]


def child(algo: str, steps: int, env_id: str, n_envs: int, seed: int) -> dict[str, float | int | str]:
    """Train in this process and return (and print as one JSON line) the memory it used."""
    import psutil
    import torch as th
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    from sb3_reinforce import REINFORCE
    from sb3_reinforce.safeguards import TrimHeap

    th.set_num_threads(1)
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    model: Any = None
    if algo == "random":  # the environment alone (random actions, no model, no torch work)
        env.action_space.seed(seed)
        env.reset()
        n_iters = max(1, steps // env.num_envs)

        def run() -> int:
            for _ in range(n_iters):
                env.step(np.array([env.action_space.sample() for _ in range(env.num_envs)]))
            return n_iters * env.num_envs

    else:
        algo_class = {"reinforce": REINFORCE, "reinforce_notrim": REINFORCE, "reinforce_value": REINFORCE, "ppo": PPO}[algo]
        kwargs = {"baseline": "value"} if algo == "reinforce_value" else {}
        model = algo_class("MlpPolicy", env, seed=seed, device="cpu", **kwargs)
        callback = TrimHeap() if algo in ("reinforce", "reinforce_value") else None

        def run() -> int:
            model.learn(steps, callback=callback)
            return model.num_timesteps

    rss_before = psutil.Process().memory_info().rss
    start = time.perf_counter()
    steps_done = run()
    seconds = time.perf_counter() - start
    rss_after = psutil.Process().memory_info().rss
    # ru_maxrss (KiB on Linux) is the kernel's high-water mark, which can lag the current RSS a little
    peak = max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 2**10, rss_after)
    result = {
        "algo": algo,
        "env_id": env_id,
        "n_envs": n_envs,
        "steps": steps_done,
        "seconds": round(seconds, 1),
        "rss_before_learn_mib": round(rss_before / 2**20, 1),
        "rss_after_learn_mib": round(rss_after / 2**20, 1),
        "peak_rss_mib": round(peak / 2**20, 1),
    }
    if algo.startswith("reinforce"):
        result["buffer_capacity_per_env"] = model.rollout_buffer.capacity
    print(json.dumps(result))
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--runs",
        nargs="+",
        default=DEFAULT_RUNS,
        help="ALGO:STEPS, ALGO in reinforce, reinforce_notrim, reinforce_value, ppo, random (the env alone)",
    )
    parser.add_argument("--env", default="LunarLander-v3")
    parser.add_argument("--n-envs", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument(
        "--in-process",
        action="store_true",
        help="run in this process instead of a fresh one (a quick check: the peak then covers every run before)",
    )
    parser.add_argument("--child", nargs=2, metavar=("ALGO", "STEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.child:
        child(args.child[0], int(args.child[1]), args.env, args.n_envs, args.seed)
        return
    rows = []
    for spec in args.runs:
        algo, steps = spec.split(":")
        if args.in_process:
            rows.append(child(algo, int(steps), args.env, args.n_envs, args.seed))
            continue
        cmd = [sys.executable, __file__, "--child", algo, steps, "--env", args.env, "--n-envs", str(args.n_envs)]
        cmd += ["--seed", str(args.seed)]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        row = json.loads(out.strip().splitlines()[-1])
        print(row, flush=True)
        rows.append(row)
    fields = list(dict.fromkeys(key for row in rows for key in row))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
