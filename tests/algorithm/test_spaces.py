"""As SB3's tests/test_spaces.py: every supported observation/action space trains; others are refused like SB3 does."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from stable_baselines3 import A2C
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.envs import FakeImageEnv, IdentityEnv, IdentityEnvBox, SimpleMultiObsEnv

from sb3_reinforce import REINFORCE


class SpaceEnv(gym.Env):
    def __init__(self, observation_space: spaces.Space, action_space: spaces.Space, ep_length: int = 7):
        self.observation_space = observation_space
        self.action_space = action_space
        self.ep_length = ep_length

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple:
        super().reset(seed=seed)
        self.t = 0
        return self.observation_space.sample(), {}

    def step(self, action: np.ndarray) -> tuple:
        self.t += 1
        return self.observation_space.sample(), 1.0, self.t >= self.ep_length, False, {}


BOX = spaces.Box(-1, 1, (3,), dtype=np.float32)


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize(
    "policy, env",
    [
        ("MlpPolicy", IdentityEnv(4)),  # Discrete observations
        ("MlpPolicy", IdentityEnvBox()),
        ("MlpPolicy", SpaceEnv(spaces.MultiDiscrete([3, 4]), spaces.MultiBinary(3))),
        ("MlpPolicy", SpaceEnv(spaces.MultiBinary(5), spaces.MultiDiscrete([2, 5]))),
        ("MlpPolicy", SpaceEnv(spaces.Box(-1, 1, (2, 3), dtype=np.float64), spaces.Box(-2, 2, (2, 2), dtype=np.float32))),
        ("CnnPolicy", FakeImageEnv(screen_height=40, screen_width=40, n_channels=1, discrete=True)),
        ("CnnPolicy", FakeImageEnv(screen_height=40, screen_width=40, n_channels=3, discrete=False)),
        ("MultiInputPolicy", SimpleMultiObsEnv(random_start=True)),
    ],
)
def test_supported_spaces(policy: str, env: gym.Env, baseline: str | None) -> None:
    check_env(env, warn=False)
    model = REINFORCE(policy, env, baseline=baseline, n_episodes=2, seed=0).learn(150)
    assert model.num_timesteps >= 150
    obs = env.observation_space.sample()
    action, _ = model.predict(obs)
    assert env.action_space.contains(action)
    for param in model.policy.parameters():
        assert np.isfinite(param.detach().numpy()).all()


def _refusal(model_class: type, env: gym.Env) -> tuple[type, str]:
    with pytest.raises(Exception) as info:  # the type is compared with A2C's below
        model_class("MlpPolicy", env)
    return info.type, str(info.value)


@pytest.mark.parametrize(
    "env",
    [
        SpaceEnv(BOX, spaces.Tuple([spaces.Discrete(2), spaces.Discrete(2)])),
        SpaceEnv(BOX, spaces.Dict({"a": spaces.Discrete(2)})),
        SpaceEnv(spaces.Tuple([BOX, BOX]), spaces.Discrete(2)),
    ],
)
def test_unsupported_spaces_refused_like_sb3(env: gym.Env) -> None:
    ours = _refusal(REINFORCE, env)
    sb3 = _refusal(A2C, env)
    assert ours[0] is sb3[0]
    assert ours[1].replace("REINFORCE", "A2C") == sb3[1] or ours[1] == sb3[1]
