"""
The logged ``time/fps`` of ``learn(100, log_interval=1)`` on one-step episodes that sleep 1 ms a step: the setting of
SB3's ``test_logger.py::test_fps_logger`` (which asks for at least 100), where REINFORCE updates once per step.

    python benchmarks/one_step_episodes.py [--models 5] [--csv benchmarks/results/one_step_episodes.csv]

For each of A2C (SB3's defaults), REINFORCE (defaults) and REINFORCE with ``baseline="value"``, fresh models, one
torch thread, as the test suite runs; each row records the 1-minute load average. Run it on an otherwise idle machine.
"""

import argparse
import csv
import os
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import A2C
from stable_baselines3.common.logger import Logger

from sb3_reinforce import REINFORCE


class OneStepSleepEnv(gym.Env):
    """Every episode ends at its first step, which sleeps ``delay`` seconds; random observations, no reward."""

    def __init__(self, delay: float = 1e-3):
        super().__init__()
        self.delay = delay
        self.observation_space = spaces.Box(low=-20.0, high=20.0, shape=(4,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        time.sleep(self.delay)
        return self.observation_space.sample(), 0.0, True, False, {}


class LastValuesLogger(Logger):
    """A logger without outputs that keeps the last recorded values (SB3's ``dump`` would clear them)."""

    def __init__(self) -> None:
        super().__init__(folder=None, output_formats=[])

    def dump(self, step: int = 0) -> None:
        pass


ALGORITHMS = {
    "A2C": lambda env: A2C("MlpPolicy", env),
    "REINFORCE": lambda env: REINFORCE("MlpPolicy", env),
    "REINFORCE value": lambda env: REINFORCE("MlpPolicy", env, baseline="value"),
}


def logged_fps(make: Any) -> float:
    """``time/fps`` as SB3 logs it at the end of ``learn(100, log_interval=1)`` of a fresh model."""
    model = make(OneStepSleepEnv())
    logger = LastValuesLogger()
    model.set_logger(logger)
    model.learn(100, log_interval=1)
    return float(logger.name_to_value["time/fps"])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--models", type=int, default=5, help="fresh models per algorithm")
    parser.add_argument("--csv", type=Path, default=None, help="write one row per model here")
    args = parser.parse_args(argv)
    th.set_num_threads(1)
    rows = []
    for name, make in ALGORITHMS.items():
        fps = []
        for index in range(args.models):
            load = os.getloadavg()[0]
            fps.append(logged_fps(make))
            rows.append({"algorithm": name, "model": index, "fps": fps[-1], "load_1min": round(load, 2)})
        print(f"{name:16s} fps {min(fps):.0f}-{max(fps):.0f}  (median {np.median(fps):.0f}, {args.models} models)")
    if args.csv is not None:
        with args.csv.open("w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    main()
