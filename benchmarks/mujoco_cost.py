"""
What a MuJoCo run costs here, measured before the study is planned (issue 45):

- ``raw``: environment steps per second with random actions, Gymnasium's ``-v4`` env against EnvPool's twin on one
  thread with 1 and with 8 environments (no policy);
- ``run``: an algorithm's training steps per second (REINFORCE's unless ``--algo``; a fresh model from a zoo entry,
  built as ``sb3-reinforce compare`` builds it, one torch thread) and the steps per second of 10 deterministic
  evaluation episodes on the run's evaluation environment (SB3's ``evaluate_policy``, as compare evaluates).

Each measurement appends a row to ``results/mujoco_cost.csv`` with the machine's load average when it started. Two
runs side by side: start the command twice at once (``--tag pair``).

    python benchmarks/mujoco_cost.py raw --envs HalfCheetah-v4 Hopper-v4 Ant-v4 Humanoid-v4
    python benchmarks/mujoco_cost.py run --envs HalfCheetah-v4 --config benchmarks/configs/mujoco_tuning/a_value4.yml
    python benchmarks/mujoco_cost.py run --algo ppo --envs Pendulum-v1 --config benchmarks/configs/defaults_study/ppo.yml
"""

import argparse
import csv
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

RESULTS = Path(__file__).parent / "results" / "mujoco_cost.csv"
COLUMNS = ["kind", "env_id", "backend", "n_envs", "config", "tag", "load_1min", "steps", "seconds", "steps_per_s"]


def raw_rates(env_id: str, steps: int) -> list[dict[str, Any]]:
    """Random-action steps per second on Gymnasium's env, then on EnvPool's with 1 and 8 envs on one thread."""
    import envpool

    rows = []
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    load = os.getloadavg()[0]
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    seconds = time.perf_counter() - start
    rows.append(dict(backend="gymnasium", n_envs=1, load_1min=load, steps=steps, seconds=seconds))
    for n_envs in (1, 8):
        pool = envpool.make_gymnasium(env_id, num_envs=n_envs, num_threads=1, seed=0)
        pool.reset()
        actions = np.stack([env.action_space.sample() for _ in range(n_envs)])
        n_calls = steps // n_envs
        load = os.getloadavg()[0]
        start = time.perf_counter()
        for _ in range(n_calls):
            pool.step(actions)  # EnvPool resets an ended environment itself
        seconds = time.perf_counter() - start
        rows.append(dict(backend="envpool", n_envs=n_envs, load_1min=load, steps=n_calls * n_envs, seconds=seconds))
    return rows


def run_rates(algo: str, env_id: str, config: Path, steps: int, seed: int) -> list[dict[str, Any]]:
    """``algo``'s training steps per second from ``config``'s entry, then 10 deterministic evaluation episodes."""
    import torch as th
    from stable_baselines3.common.evaluation import evaluate_policy

    from sb3_reinforce.lab.compare.experiment import build_run

    th.set_num_threads(1)
    with tempfile.TemporaryDirectory() as log_folder:
        built = build_run(algo, env_id, seed, steps, Path(log_folder), config=config)
        load = os.getloadavg()[0]
        start = time.perf_counter()
        built.model.learn(steps)
        train_s = time.perf_counter() - start
        eval_load = os.getloadavg()[0]
        start = time.perf_counter()
        _, lengths = evaluate_policy(built.model, built.eval_env, n_eval_episodes=10, return_episode_rewards=True)
        eval_s = time.perf_counter() - start
        built.train_env.close()
        built.eval_env.close()
    n_envs = built.entry.n_envs
    return [
        dict(backend="gymnasium", n_envs=n_envs, load_1min=load, steps=built.model.num_timesteps, seconds=train_s),
        dict(kind="evaluation", backend="gymnasium", n_envs=1, load_1min=eval_load, steps=sum(lengths), seconds=eval_s),
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=["raw", "run"])
    parser.add_argument("--envs", nargs="+", default=["HalfCheetah-v4", "Hopper-v4"])
    parser.add_argument("--steps", type=int, default=None, help="steps per measurement (raw: 5,000; run: 30,000)")
    parser.add_argument("--algo", default="reinforce", help="the algorithm (run), as compare's --algos")
    parser.add_argument("--config", type=Path, default=None, help="the algorithm's zoo yml (run)")
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--tag", default="alone", help="recorded as is: 'alone', or 'pair' for two at once")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")  # Gymnasium's "-v4 is out of date" and EnvPool's float32 notes
    new_file = not args.out.exists()
    with args.out.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()
        for env_id in args.envs:
            if args.kind == "raw":
                rows = raw_rates(env_id, args.steps or 5_000)
            else:
                assert args.config is not None, "run needs --config"
                rows = run_rates(args.algo, env_id, args.config, args.steps or 30_000, args.seed)
            for row in rows:
                row = {"kind": args.kind, **row, "env_id": env_id, "tag": args.tag}
                row["config"] = args.config.stem if args.config else ""
                row["steps_per_s"] = round(row["steps"] / row["seconds"], 1)
                row["seconds"] = round(row["seconds"], 3)
                row["load_1min"] = round(row["load_1min"], 2)
                writer.writerow(row)
                file.flush()
                print(", ".join(f"{key}={row[key]}" for key in COLUMNS))


if __name__ == "__main__":
    main()
