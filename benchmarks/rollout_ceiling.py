"""
Where the CPU time of ``REINFORCE.learn()`` goes, next to the environment's own cost, and the ceiling that sets.

For each repeat, in one process with torch on 1 thread:

1. ``learn(steps)`` from a fresh model, with CPU-time counters (``time.process_time``) wrapped around each part
   it calls: the VecEnv's ``step``, action sampling (``FastSampler``), the buffer's ``add``, the NaN/inf check,
   the episode-info bookkeeping, ``compute_returns``, ``train()``. What no counter covers is the loop itself,
   SB3's callbacks and logging, and the per-rollout setup ("rest"). The wrappers cost well under a microsecond
   per call, included in the parts.
2. The same VecEnv, freshly built with the same seed, stepped alone with pre-drawn random actions as many
   times as ``learn`` stepped it ("env alone": ``throughput.py``'s ``raw``, its own code, timed in CPU time).

CPU time, not wall-clock: on a shared machine other processes inflate wall-clock time at random, while the CPU
time of a single-threaded process barely moves. The ratios below are those of ``throughput.py`` (steps per
second = steps / seconds), computed from CPU seconds:

- ``R/raw``: env alone / whole ``learn``: REINFORCE's rate as a fraction of the raw environment rate;
- ``bound: env only``: env alone / env inside ``learn``: the rate ``learn`` would reach if everything but the
  environment cost nothing (the environment runs slower inside a learning loop than alone);
- ``bound: no train``: env alone / (``learn`` minus ``train``): the rate with free gradient steps.

Usage::

    python benchmarks/rollout_ceiling.py --env CartPole-v1 --n-envs 8 --steps 4096 --repeats 5 \\
        --out benchmarks/results/rollout_ceiling.csv
"""

import argparse
import csv
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from throughput import make_env, time_raw  # benchmarks/throughput.py, next to this script

from sb3_reinforce import REINFORCE

PARTS = ("env step", "sampling", "buffer add", "episode info", "compute_returns", "train")


def _timed(function: Callable[..., Any], part: str, totals: dict[str, float]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            totals[part] += time.process_time() - start

    return wrapper


def split_learn(env_id: str, n_envs: int, steps: int, seed: int) -> tuple[dict[str, float], int, int]:
    """CPU seconds per part of one ``learn(steps)``; also the VecEnv steps taken and the gradient steps."""
    totals: dict[str, float] = defaultdict(float)
    env = make_env(env_id, n_envs, seed)
    model = REINFORCE("MlpPolicy", env, seed=seed, device="cpu")
    vec_steps = 0

    def count_step(actions: np.ndarray) -> Any:
        nonlocal vec_steps
        vec_steps += 1
        return env_step(actions)

    env_step = _timed(env.step, "env step", totals)
    env.step = count_step  # type: ignore[method-assign]
    make_sampler = model.policy.fast_sampler

    def timed_sampler() -> Any:
        sampler = make_sampler()
        return None if sampler is None else _timed(sampler, "sampling", totals)

    model.policy.fast_sampler = timed_sampler  # type: ignore[method-assign]
    model._update_info_buffer = _timed(model._update_info_buffer, "episode info", totals)  # type: ignore[method-assign]
    model.train = _timed(model.train, "train", totals)  # type: ignore[method-assign]
    buffer = model.rollout_buffer
    buffer.add = _timed(buffer.add, "buffer add", totals)  # type: ignore[method-assign]
    buffer.compute_returns = _timed(buffer.compute_returns, "compute_returns", totals)  # type: ignore[method-assign]

    start = time.process_time()
    model.learn(steps)
    totals["learn"] = time.process_time() - start
    env.close()
    return dict(totals), vec_steps, model._n_updates


def env_alone(env_id: str, n_envs: int, vec_steps: int, seed: int) -> float:
    """CPU seconds of ``vec_steps`` steps of the same VecEnv with pre-drawn random actions."""
    env = make_env(env_id, n_envs, seed)
    _, seconds = time_raw(env, vec_steps * n_envs, seed, clock=time.process_time)
    env.close()
    return seconds


def run(env_id: str, n_envs: int, steps: int, repeats: int, seed: int) -> dict[str, Any]:
    """Median over repeats of every part (CPU ms per ``learn(steps)``) and of the ratios."""
    th.set_num_threads(1)
    rows = []
    for repeat in range(repeats):
        parts, vec_steps, updates = split_learn(env_id, n_envs, steps, seed + repeat)
        alone = env_alone(env_id, n_envs, vec_steps, seed + repeat)
        learn = parts["learn"]
        rows.append(
            {
                **{f"{part} ms": 1000 * parts.get(part, 0.0) for part in PARTS},
                "rest ms": 1000 * (learn - sum(parts.get(part, 0.0) for part in PARTS)),
                "learn ms": 1000 * learn,
                "env alone ms": 1000 * alone,
                "updates": updates,
                "vec_env steps": vec_steps,
                "R/raw": alone / learn,
                "bound: env only": alone / parts["env step"],
                "bound: no train": alone / (learn - parts["train"]),
            }
        )
    summary: dict[str, Any] = {"env_id": env_id, "n_envs": n_envs, "steps": steps, "repeats": repeats}
    for key in rows[0]:
        summary[key] = round(statistics.median(row[key] for row in rows), 3)
    return summary


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", nargs="+", default=["CartPole-v1"])
    parser.add_argument("--n-envs", nargs="+", type=int, default=[8])
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="CSV to write (default: print only)")
    args = parser.parse_args(argv)
    summaries = [run(env_id, n, args.steps, args.repeats, args.seed) for env_id in args.env for n in args.n_envs]
    print(f"torch {th.__version__}, 1 thread, CPU time, median of {args.repeats} x learn({args.steps}) from scratch")
    for summary in summaries:
        learn = summary["learn ms"]
        print(f"\n{summary['env_id']}, {summary['n_envs']} envs: {summary['updates']:g} updates")
        print("| part | CPU ms | share of learn |\n|---|---:|---:|")
        for part in (*PARTS, "rest"):
            print(f"| {part} | {summary[part + ' ms']:.1f} | {100 * summary[part + ' ms'] / learn:.1f} % |")
        print(f"| **learn** | {learn:.1f} | 100 % |\n| env alone (same steps) | {summary['env alone ms']:.1f} | |")
        print(
            f"R/raw {summary['R/raw']:.2f}; bound if only the env cost anything {summary['bound: env only']:.2f}; "
            f"bound with free gradient steps {summary['bound: no train']:.2f}"
        )
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=list(summaries[0]))
            writer.writeheader()
            writer.writerows(summaries)
        print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
