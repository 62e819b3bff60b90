"""
How long a uniformly random policy takes to reach MountainCar's flag without a time limit (the seed's setup):
10 episodes, seeds 0-9, written to benchmarks/results/mountaincar_random_policy.csv.

    python benchmarks/mountaincar_random_policy.py
"""

import dataclasses
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd

OUT = Path(__file__).parent / "results" / "mountaincar_random_policy.csv"


def main() -> None:
    env = gym.make(dataclasses.replace(gym.spec("MountainCar-v0"), max_episode_steps=None))
    rng = np.random.default_rng(0)
    rows = []
    for seed in range(10):
        env.reset(seed=seed)
        steps, terminated = 0, False
        while not terminated and steps < 2_000_000:
            _, _, terminated, _, _ = env.step(int(rng.integers(3)))
            steps += 1
        rows.append(dict(seed=seed, steps_to_flag=steps, reached=terminated))
    table = pd.DataFrame(rows)
    table.to_csv(OUT, index=False)
    print(table.to_string(index=False))
    print(f"median steps to the flag: {table['steps_to_flag'].median():,.0f} -> {OUT}")


if __name__ == "__main__":
    main()
