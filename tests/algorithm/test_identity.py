"""As SB3's tests/test_identity.py: REINFORCE must actually learn the identity envs, and CartPole."""

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.callbacks import EvalCallback, StopTrainingOnRewardThreshold
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.envs import IdentityEnv, IdentityEnvBox, IdentityEnvMultiBinary, IdentityEnvMultiDiscrete
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE

DIM = 4


@pytest.mark.parametrize(
    "env, n_steps, kwargs",
    [
        (IdentityEnv(DIM), 3000, {}),
        (IdentityEnvMultiDiscrete(DIM), 3000, {}),
        (IdentityEnvMultiBinary(DIM), 8000, dict(learning_rate=3e-3)),
    ],
)
def test_discrete(env: gym.Env, n_steps: int, kwargs: dict) -> None:
    env_ = DummyVecEnv([lambda: env])
    model = REINFORCE("MlpPolicy", env_, gamma=0.4, seed=1, **kwargs).learn(n_steps)
    evaluate_policy(model, env_, n_eval_episodes=20, reward_threshold=90, warn=False)
    obs = env.reset()[0]
    assert np.shape(model.predict(obs)[0]) == np.shape(env.action_space.sample())


@pytest.mark.parametrize("baseline", [None, "value"])
def test_continuous(baseline: str | None) -> None:
    env = IdentityEnvBox(eps=0.5)
    model = REINFORCE("MlpPolicy", env, gamma=0.95, seed=1, baseline=baseline).learn(6000)
    mean_reward, _ = evaluate_policy(model, env, n_eval_episodes=20, warn=False)
    assert mean_reward >= 90, mean_reward  # of 100: within eps of the target on at least 90% of the steps


@pytest.mark.parametrize("baseline", [None, "value"])
def test_cartpole_solved(baseline: str | None) -> None:
    """CartPole-v1 to a mean evaluation return >= 475 within 50k steps (defaults, one episode per update)."""
    # A seeded evaluation env: the early stop and the final check are then reproducible.
    eval_env = make_vec_env("CartPole-v1", n_envs=1, seed=123)
    stop = StopTrainingOnRewardThreshold(reward_threshold=475, verbose=0)
    eval_callback = EvalCallback(eval_env, eval_freq=2000, n_eval_episodes=10, callback_on_new_best=stop, verbose=0)
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0, baseline=baseline)
    model.learn(50_000, callback=eval_callback)
    assert model.num_timesteps < 50_000, f"not solved within 50k steps (best {eval_callback.best_mean_reward})"
    mean_reward, _ = evaluate_policy(model, eval_env, n_eval_episodes=20, warn=False)
    assert mean_reward >= 475 - 25, mean_reward  # the solving policy, re-evaluated on 20 fresh episodes
