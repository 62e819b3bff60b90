"""
The environments as the seed's scripts (github.com/gabrielgarza/openai-gym-policy-gradient) ran them.

    env = make_seed_env("CarRacing-v3")
    model = REINFORCE(env=env, **seed_hyperparams("CarRacing-v3"))

- ``MountainCar``: no time limit (an overlong episode raises ``RolloutLimitError`` at ``max_rollout_steps``).
- ``CarRacing``: 502-step episodes, 48x48 grayscale pixels flattened (2,304 values in [0, 255], unscaled),
  one-hot actions (steer right, gas, brake).
- Others: the registered time limit, a deliberate difference (docs/guide/seed.md).
"""

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

__all__ = ["SEED_EPISODE_LIMITS", "OneHotActions", "SeedPixels", "make_seed_env"]

#: Episode limit per env family (``None``: no limit); families not listed keep the registered limit.
SEED_EPISODE_LIMITS: dict[str, int | None] = {"MountainCar": None, "CarRacing": 502}

#: The ITU-R 601 luma weights the seed's CarRacing script used for grayscale (``np.dot(obs[..., :3], w)``).
LUMA_WEIGHTS = np.array([0.299, 0.587, 0.114])


class SeedPixels(gym.ObservationWrapper):
    """
    The seed's CarRacing preprocessing: grayscale, every second row and column, flattened (float, [0, 255]).

    :param env: An environment with ``(H, W, 3)`` image observations
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        shape = env.observation_space.shape
        if not isinstance(env.observation_space, spaces.Box) or shape is None or len(shape) != 3 or shape[2] != 3:
            raise ValueError(f"SeedPixels needs (H, W, 3) RGB observations, got {env.observation_space}")
        size = ((shape[0] + 1) // 2) * ((shape[1] + 1) // 2)
        self.observation_space = spaces.Box(low=0.0, high=255.0, shape=(size,), dtype=np.float32)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        gray = np.dot(observation[..., :3], LUMA_WEIGHTS)
        return gray[::2, ::2].astype(np.float32).ravel()


class OneHotActions(gym.ActionWrapper):
    """
    The seed's discrete actions for a ``Box`` space: action ``i`` sets dimension ``i`` to 1, the others to 0.

    :param env: An environment with a one-dimensional ``Box`` action space whose bounds contain 0 and 1
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        space = env.action_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ValueError(f"OneHotActions needs a one-dimensional Box action space, got {space}")
        self.action_space = spaces.Discrete(space.shape[0])
        self._box = space

    def action(self, action: Any) -> np.ndarray:
        one_hot = np.zeros(self._box.shape, dtype=self._box.dtype)
        one_hot[int(action)] = 1
        return one_hot


def make_seed_env(env_id: str, **kwargs: Any) -> gym.Env:
    """
    Make ``env_id`` as the seed's script for its family ran it (see the module docstring).

    :param env_id: A registered Gymnasium env id
    :param kwargs: Passed on to ``gym.make``
    :return: The environment (without ``Monitor``)
    """
    family = env_id.split("-")[0]
    if family not in SEED_EPISODE_LIMITS:
        return gym.make(env_id, **kwargs)
    limit = SEED_EPISODE_LIMITS[family]
    # Drop the registered limit from the spec so gym.make keeps its other wrappers
    spec = dataclasses.replace(gym.spec(env_id), max_episode_steps=None)
    env = gym.make(spec, max_episode_steps=limit, **kwargs)
    if family == "CarRacing":
        env = OneHotActions(SeedPixels(env))
    return env
