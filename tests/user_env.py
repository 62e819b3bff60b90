"""
A user's own environment, as a package of theirs would register it: ``Reach1D-v0``, for ``sb3-reinforce compare
--gym-packages tests.user_env`` (the README's example) and its tests. No zoo file has an entry for it.

A point starts at a random place in [-1, 1] and moves left or right by 0.1 a step; each step costs its distance to
0, and the episode ends when it is within 0.05 of 0 (or after 50 steps). Going straight to 0 scores about -1.8 on
average; a random walk, about -20.
"""

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

__all__ = ["Reach1D"]


class Reach1D(gym.Env):
    """Move a point on a line to 0 (see the module docstring)."""

    def __init__(self) -> None:
        self.observation_space = spaces.Box(-2.0, 2.0, shape=(1,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)
        self.x = 0.0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.x = float(self.np_random.uniform(-1.0, 1.0))
        return np.array([self.x], dtype=np.float32), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.x = float(np.clip(self.x + (0.1 if action == 1 else -0.1), -2.0, 2.0))
        return np.array([self.x], dtype=np.float32), -abs(self.x), abs(self.x) < 0.05, False, {}


gym.register("Reach1D-v0", entry_point=Reach1D, max_episode_steps=50, reward_threshold=-3.0)
