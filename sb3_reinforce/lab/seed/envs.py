"""
The environment side of the seed's scripts (github.com/gabrielgarza/openai-gym-policy-gradient):
which time limit each ran with, and the CarRacing script's own pixel preprocessing and discrete actions.

    env = make_seed_env("CarRacing-v3")
    model = REINFORCE(env=env, **seed_hyperparams("CarRacing-v3"))

The seed ran every env unwrapped (no time limit). This re-run does the same where the missing limit is part of the
experiment or where the seed's script bounded its episodes itself:

- ``MountainCar``: no time limit, as the seed (``env.unwrapped``). A random policy reaches the flag eventually;
  an episode that does not end within the model's ``max_rollout_steps`` raises ``RolloutLimitError``.
- ``CarRacing``: episodes end after 502 steps (the script's ``if steps_taken_in_episode > 500: done = True``,
  checked before the counter moves), observations are the script's 48x48 grayscale pixels flattened to 2,304
  values in [0, 255] (unscaled, as the script fed them to its network), and the policy picks one of the three
  action dimensions to set to 1 (steer right, gas, brake), as the script did.
- The others (``LunarLander``, ``CartPole``, ``Acrobot``): the registered time limit, on purpose, instead of the
  seed's unwrapped env and 120-second wall-clock cut (see :mod:`sb3_reinforce.lab.seed.reproduction`).
"""

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

__all__ = ["SEED_EPISODE_LIMITS", "OneHotActions", "SeedPixels", "make_seed_env"]

#: Episode length of each of the seed's scripts where this re-run follows it: ``None`` is no time limit (the
#: seed's unwrapped env), a number the script's own cut. Families not listed keep the registered time limit.
SEED_EPISODE_LIMITS: dict[str, int | None] = {"MountainCar": None, "CarRacing": 502}

#: The ITU-R 601 luma weights the seed's CarRacing script used for grayscale (``np.dot(obs[..., :3], w)``).
LUMA_WEIGHTS = np.array([0.299, 0.587, 0.114])


class SeedPixels(gym.ObservationWrapper):
    """
    The seed's CarRacing preprocessing: RGB to grayscale (luma weights), every second row and column kept
    (96x96 to 48x48), flattened to one float vector of 2,304 values in [0, 255].

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
    Discrete actions for a ``Box`` action space as the seed's CarRacing script made them: action ``i`` sets
    dimension ``i`` to 1 and the others to 0 (CarRacing: steer right, gas, brake; steering left is never
    chosen, as in the seed).

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
    # A spec without the registered limit: gym.make keeps its other wrappers (order enforcing, checker)
    spec = dataclasses.replace(gym.spec(env_id), max_episode_steps=None)
    env = gym.make(spec, max_episode_steps=limit, **kwargs)
    if family == "CarRacing":
        env = OneHotActions(SeedPixels(env))
    return env
