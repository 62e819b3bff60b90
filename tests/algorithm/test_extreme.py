"""Extreme episodes: length 1, 100,000+ steps, rewards from 1e-8 to 1e8, gamma 0 and 1, NaN/inf from the env."""

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards import CheckFinite, NonFiniteError
from tests.envs import CountingEnv


class ScaledEnv(gym.Env):
    """Episodes of ``length`` steps; reward ``scale * (1 + action)`` (so actions matter), observation ``t / length``."""

    def __init__(self, length: int, scale: float = 1.0, bad: str | None = None, bad_at: int = 3):
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(1,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)
        self.length, self.scale, self.bad, self.bad_at = length, scale, bad, bad_at
        self.t = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.t += 1
        obs = np.array([self.t / self.length], dtype=np.float32)
        reward = self.scale * (1.0 + int(action))
        if self.t == self.bad_at and self.bad is not None:
            value = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}[self.bad.split("_")[1]]
            if self.bad.startswith("reward"):
                reward = value
            else:
                obs[0] = value
        return obs, reward, self.t >= self.length, False, {}


def finite(model: REINFORCE) -> bool:
    return all(th.isfinite(p).all() for p in model.policy.parameters())


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize("gamma", [0.0, 1.0])
def test_length_one_episodes(gamma: float, baseline: str | None) -> None:
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: ScaledEnv(1)] * 2), gamma=gamma, baseline=baseline, seed=0)
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(60)
    assert model._n_updates == 30 and finite(model)
    assert not all(th.equal(a, b) for a, b in zip(before, model.policy.parameters(), strict=True)), "it learned"


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize("normalize", [True, False])
@pytest.mark.parametrize("scale", [1e-8, -1e-8, 1e8, -1e8])
def test_reward_scales_stay_finite(scale: float, normalize: bool, baseline: str | None) -> None:
    env = DummyVecEnv([lambda: ScaledEnv(20, scale)])
    model = REINFORCE("MlpPolicy", env, gamma=1.0, baseline=baseline, normalize_returns=normalize, seed=0)
    model.learn(200, log_interval=10_000)  # nothing dumped: the last update's values stay in the logger
    logged = model.logger.name_to_value
    assert model._n_updates == 10 and finite(model)
    for key in ("train/loss", "train/policy_loss", "train/grad_norm"):
        assert math.isfinite(logged[key]), key
    if baseline is not None:
        assert math.isfinite(logged["train/value_loss"])


@pytest.mark.parametrize("gamma", [0.0, 1.0])
def test_gamma_extremes_returns(gamma: float) -> None:
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: CountingEnv(0, (4,))]), gamma=gamma, normalize_returns=False)
    model.learn(4)
    # CountingEnv rewards 1, 2, 3, 4: gamma 0 gives the rewards, gamma 1 the undiscounted reward-to-go
    expected = [1.0, 2.0, 3.0, 4.0] if gamma == 0.0 else [10.0, 9.0, 7.0, 4.0]
    np.testing.assert_allclose(model.rollout_buffer.returns, expected)


@pytest.mark.parametrize("baseline", [None, "value"])
def test_episode_of_100k_steps_bounded_memory(baseline: str | None) -> None:
    """
    One 120,000-step episode (gamma 1, reward -1 or -2 per step), stored and trained on: one finite update,
    and the buffer holds that episode and no more. The steps are fed to the buffer directly (the policy's
    per-step forward pass would make this minutes long on CI); the buffer, returns and update are the real ones.
    """
    length = 120_000
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: ScaledEnv(length, -1.0)]), gamma=1.0, baseline=baseline, seed=0)
    model.set_logger(Logger(folder=None, output_formats=[]))
    buffer = model.rollout_buffer
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 2, size=length)
    for t in range(length):
        buffer.add(
            np.array([[t / length]], dtype=np.float32),
            actions[t : t + 1],
            -1.0 - actions[t : t + 1],
            np.array([t == length - 1]),
        )
    assert buffer.is_full
    buffer.compute_returns()
    assert (
        buffer.batch_size == length
        and buffer.returns[0] == -float(length + actions.sum())
        and buffer.returns[-1] == -1.0 - actions[-1]
    )
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.train()
    assert finite(model) and not all(th.equal(a, b) for a, b in zip(before, model.policy.parameters(), strict=True))
    assert all(math.isfinite(model.logger.name_to_value[key]) for key in ("train/loss", "train/grad_norm"))
    # Capacity doubles from 256: 2^19 = 131,072 rows, the first power-of-two multiple of 256 above the episode.
    assert buffer.capacity == 256 * 2**9
    per_row = 4 + 4 + 8 + 1  # float32 obs, float32 action, float64 reward, bool episode end
    stored = sum(array.nbytes for array in buffer._storage.values())
    assert stored == buffer.capacity * per_row < 2 * length * per_row


def test_never_ending_episode_hits_the_cap() -> None:
    from sb3_reinforce import RolloutLimitError

    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: ScaledEnv(10**9)]), max_rollout_steps=5_000, seed=0)
    with pytest.raises(RolloutLimitError, match="max_rollout_steps=5000"):  # the argument, by its name (issue 62)
        model.learn(10_000)
    assert model.rollout_buffer.capacity <= 5_000


BAD = ["reward_nan", "reward_inf", "reward_-inf", "obs_nan", "obs_inf", "obs_-inf"]


@pytest.mark.parametrize("bad", BAD)
def test_non_finite_names_env_and_leaves_weights(bad: str) -> None:
    env = DummyVecEnv([lambda: ScaledEnv(10), lambda: ScaledEnv(10, bad=bad)])
    model = REINFORCE("MlpPolicy", env, seed=0)
    before = [p.detach().clone() for p in model.policy.parameters()]
    what = "reward" if bad.startswith("reward") else "observation"
    with pytest.raises(NonFiniteError, match=f"Environment 1 returned a non-finite {what} at timestep 6"):
        model.learn(100, callback=CheckFinite())
    assert all(th.equal(a, b) for a, b in zip(before, model.policy.parameters(), strict=True))
    assert model._n_updates == 0 and model.num_timesteps == 2 * 3, "stopped at the bad step, before any update"


def test_non_finite_terminal_observation_when_bootstrapped() -> None:
    class BadTerminal(ScaledEnv):
        def step(self, action: int) -> tuple:
            obs, reward, terminated, _, info = super().step(action)
            if terminated:
                obs[0] = math.nan
            return obs, reward, False, terminated, info  # a truncation: with a baseline, V(terminal obs) is used

    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: BadTerminal(4)]), baseline="value", seed=0)
    with pytest.raises(NonFiniteError, match="Environment 0 returned a non-finite terminal observation"):
        model.learn(20, callback=CheckFinite())


@pytest.mark.parametrize("where", ["obs", "action"])
def test_discrete_start_refused(where: str) -> None:
    class Shifted(ScaledEnv):
        def __init__(self) -> None:
            super().__init__(3)
            if where == "obs":
                self.observation_space = spaces.Discrete(3, start=1)
            else:
                self.action_space = spaces.Discrete(2, start=-1)

    with pytest.raises(ValueError, match=f"{'observation' if where == 'obs' else 'action'} space .* start=-?1"):
        REINFORCE("MlpPolicy", DummyVecEnv([Shifted]))
