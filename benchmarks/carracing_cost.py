"""
What a CarRacing-v3 run costs here, measured before the 4M-step runs are planned (issue 63).

One measurement builds a fresh run from a zoo entry as ``sb3-reinforce compare`` builds it (training environments on
EnvPool, one torch thread, the run's own evaluation environment on Gymnasium), trains ``--steps`` steps, then plays
one deterministic evaluation episode, and appends a row to ``results/carracing_cost.csv``: training steps per second,
evaluation steps per second, and the machine's load average when it started. Two runs side by side: start the
command twice at once (``--tag pair``).

With ``--profile``, training runs under cProfile and the row also gives the share of the profiled time of each part
of an update cycle: the training VecEnv's ``step`` (EnvPool, the frame stack, ``VecNormalize``, ``VecMonitor``),
the policy's forward pass while acting, the buffer, and the update (for REINFORCE: the policy's step, then the value
steps; for PPO: its epochs). cProfile slows Python code more than C++ and torch, so shares are indicative and
steps/s come from unprofiled runs.

    python benchmarks/carracing_cost.py --algo reinforce
    python benchmarks/carracing_cost.py --algo ppo --steps 8192
    python benchmarks/carracing_cost.py --algo reinforce --profile
"""

import argparse
import cProfile
import csv
import os
import pstats
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).parent / "results" / "carracing_cost.csv"
ENV_ID = "CarRacing-v3"
# (label, file suffix, function, callers counted: an empty tuple counts every call)
PARTS = [
    ("vec_env step", "base_vec_env.py", "step", ("collect_rollouts",)),
    ("acting: fast sampler", "sampling.py", "__call__", ("collect_rollouts",)),
    ("acting: policy distribution", "policies.py", "get_distribution", ("collect_rollouts",)),
    ("acting: policy forward", "policies.py", "forward", ()),  # PPO: called through nn.Module.__call__
    ("buffer add", "buffers.py", "add", ("collect_rollouts",)),
    ("returns", "buffers.py", "compute_returns", ()),
    ("returns", "buffers.py", "compute_returns_and_advantage", ()),
    ("update", "reinforce.py", "train", ()),
    ("update", "ppo.py", "train", ()),
    ("update: value steps", "reinforce.py", "_fit_value", ()),
]
COLUMNS = ["algo", "tag", "profiled", "load_1min", "steps", "train_s", "train_steps_per_s", "eval_steps_per_s"]
COLUMNS += sorted({label for label, *_ in PARTS})


def parts_of(profiler: cProfile.Profile) -> tuple[dict[str, float], float]:
    """The cumulative seconds of each part of ``PARTS`` and of ``learn`` in a finished profile."""
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    seconds: dict[str, float] = {}
    total = 0.0
    for (filename, _, name), (_, _, _, cumtime, callers) in stats.items():
        if filename.endswith("on_policy_algorithm.py") and name == "learn":
            total = cumtime
        for label, suffix, function, counted_callers in PARTS:
            if filename.endswith(suffix) and name == function:
                if counted_callers:
                    cumtime = sum(c[3] for (_, _, caller), c in callers.items() if caller in counted_callers)
                seconds[label] = seconds.get(label, 0.0) + cumtime
    return seconds, total


def measure(algo: str, steps: int, seed: int, profile: bool) -> dict[str, Any]:
    """Train ``steps`` steps of a fresh ``algo`` run, then play one deterministic evaluation episode."""
    import torch as th
    from stable_baselines3.common.evaluation import evaluate_policy

    from sb3_reinforce.lab.compare.experiment import build_run

    th.set_num_threads(1)
    row: dict[str, Any] = dict(algo=algo, profiled=profile)
    with tempfile.TemporaryDirectory() as log_folder:
        built = build_run(algo, ENV_ID, seed, steps, Path(log_folder), vec_env="envpool")
        profiler = cProfile.Profile()
        row["load_1min"] = round(os.getloadavg()[0], 2)
        start = time.perf_counter()
        if profile:
            profiler.enable()
        built.model.learn(steps)
        profiler.disable()
        row["train_s"] = round(time.perf_counter() - start, 2)
        row["steps"] = built.model.num_timesteps
        row["train_steps_per_s"] = round(row["steps"] / row["train_s"], 1)
        start = time.perf_counter()
        _, lengths = evaluate_policy(built.model, built.eval_env, n_eval_episodes=1, return_episode_rewards=True)
        row["eval_steps_per_s"] = round(sum(lengths) / (time.perf_counter() - start), 1)
        built.train_env.close()
        built.eval_env.close()
    if profile:
        seconds, total = parts_of(profiler)
        for label, value in seconds.items():
            row[label] = f"{100 * value / total:.1f}%"
    return row


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", choices=["reinforce", "ppo"], default="reinforce")
    parser.add_argument("--steps", type=int, default=8_000, help="training steps (REINFORCE: 2,000 per update)")
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--profile", action="store_true", help="train under cProfile and give each part's share")
    parser.add_argument("--tag", default="alone", help="recorded as is: 'alone', or 'pair' for two at once")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")  # EnvPool's and Gymnasium's notes
    row = measure(args.algo, args.steps, args.seed, args.profile)
    row["tag"] = args.tag
    new_file = not args.out.exists()
    with args.out.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()
        writer.writerow(row)
    print(", ".join(f"{key}={row[key]}" for key in COLUMNS if key in row))


if __name__ == "__main__":
    main()
