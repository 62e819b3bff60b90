"""
Gradient clipping with and without a value baseline, on CartPole-v1: the measurement behind
REINFORCE's default ``max_grad_norm=None``.

For each configuration and seed, train with an EvalCallback (every 2,000 steps, 10 deterministic episodes)
until the evaluation mean reaches 475 or the budget runs out, and record the steps it took.

    python benchmarks/grad_clip_ablation.py            # 5 seeds, 60k-step budget, ~10 min on one core
    python benchmarks/grad_clip_ablation.py --seeds 2 --budget 5000 --out /tmp/x   # smoke run

Writes ``<out>/runs.csv`` (one row per configuration and seed, appended as runs finish) and prints a summary.
"""

import argparse
import csv
import pathlib
import time

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.callbacks import EvalCallback, StopTrainingOnRewardThreshold

from sb3_reinforce import REINFORCE

CONFIGS = {
    "no_baseline_clip_0.5": dict(baseline=None, max_grad_norm=0.5),
    "no_baseline_no_clip": dict(baseline=None, max_grad_norm=None),
    "value_baseline_clip_0.5": dict(baseline="value", max_grad_norm=0.5),
    "value_baseline_no_clip": dict(baseline="value", max_grad_norm=None),
}
THRESHOLD = 475.0


def run(config: str, seed: int, budget: int) -> dict:
    start = time.perf_counter()
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=seed, **CONFIGS[config])  # type: ignore[arg-type]
    stop = StopTrainingOnRewardThreshold(reward_threshold=THRESHOLD, verbose=0)
    eval_env = gym.make("CartPole-v1")
    eval_env.reset(seed=10_000 + seed)
    callback = EvalCallback(eval_env, eval_freq=2000, n_eval_episodes=10, callback_on_new_best=stop, verbose=0)
    model.learn(budget, callback=callback)
    solved = callback.best_mean_reward >= THRESHOLD
    return dict(
        config=config,
        seed=seed,
        solved=solved,
        steps_to_475=model.num_timesteps if solved else "",
        best_eval=callback.best_mean_reward,
        seconds=round(time.perf_counter() - start, 1),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--budget", type=int, default=60_000)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path(__file__).parent / "results" / "grad_clip")
    args = parser.parse_args()
    th.set_num_threads(1)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "runs.csv"
    rows = []
    with path.open("w", newline="") as file:
        writer = None
        for config in CONFIGS:
            for seed in range(args.seeds):
                row = run(config, seed, args.budget)
                rows.append(row)
                if writer is None:
                    writer = csv.DictWriter(file, fieldnames=list(row))
                    writer.writeheader()
                writer.writerow(row)
                file.flush()
                print(row, flush=True)
    print(f"\nSteps to a 10-episode evaluation mean >= {THRESHOLD} (budget {args.budget}, {args.seeds} seeds):")
    for config in CONFIGS:
        steps = [r["steps_to_475"] for r in rows if r["config"] == config]
        reached = sorted(s for s in steps if s != "")
        median = f"{np.median([s if s != '' else np.inf for s in steps]):.0f}"
        print(f"  {config:26s} solved {len(reached)}/{len(steps)}  steps {reached}  median {median}")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
