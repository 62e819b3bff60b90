"""Small environments the tests can reason about exactly."""

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class CountingEnv(gym.Env):
    """
    Observation ``[env_id, serial, t]``: ``serial`` numbers every observation this env ever emits, ``t`` is the
    step within the episode. Reward at step ``t`` is ``t + 1``. Episode lengths cycle through ``lengths``,
    so returns are known in closed form. Ends by termination, or by truncation when ``truncate`` is set.
    """

    def __init__(self, env_id: int = 0, lengths: tuple[int, ...] = (3, 5, 2), truncate: bool = False):
        self.env_id = env_id
        self.lengths = lengths
        self.truncate = truncate
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)
        self.action_space = spaces.Discrete(2)
        self.serial = -1
        self.n_episodes = 0
        self.t = 0

    def _obs(self) -> np.ndarray:
        self.serial += 1
        return np.array([self.env_id, self.serial, self.t], dtype=np.float64)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.t = 0
        self.length = self.lengths[self.n_episodes % len(self.lengths)]
        self.n_episodes += 1
        return self._obs(), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        reward = float(self.t + 1)
        self.t += 1
        done = self.t >= self.length
        return self._obs(), reward, done and not self.truncate, done and self.truncate, {}
