"""REINFORCE with SB3's VecEnvs, wrappers, evaluation and loggers."""

import os
import pathlib

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.logger import configure
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

from sb3_reinforce import REINFORCE


def test_vec_normalize(tmp_path: pathlib.Path) -> None:
    env = VecNormalize(make_vec_env("Pendulum-v1", n_envs=2, seed=0), gamma=0.9)
    model = REINFORCE("MlpPolicy", env, gamma=0.9, baseline="value", seed=0).learn(1200)
    assert env.obs_rms.count > 1200
    model.save(tmp_path / "model")
    env.save(str(tmp_path / "vecnormalize.pkl"))
    eval_env = VecNormalize.load(str(tmp_path / "vecnormalize.pkl"), make_vec_env("Pendulum-v1", n_envs=1))
    eval_env.training, eval_env.norm_reward = False, False
    mean, _ = evaluate_policy(REINFORCE.load(tmp_path / "model", env=eval_env), eval_env, n_eval_episodes=2)
    assert np.isfinite(mean)


def test_subproc_vec_env() -> None:
    env = make_vec_env("CartPole-v1", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
    try:
        model = REINFORCE("MlpPolicy", env, n_episodes=2, seed=0).learn(1000)
        assert model.num_timesteps >= 1000
        assert len(model.ep_info_buffer) > 0
    finally:
        env.close()


def test_evaluate_policy() -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0).learn(500)
    rewards, lengths = evaluate_policy(
        model, gym.make("CartPole-v1"), n_eval_episodes=3, return_episode_rewards=True, warn=False
    )
    assert len(rewards) == len(lengths) == 3


def _tensorboard_tags(log_dir: pathlib.Path) -> set[str]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    accumulator = EventAccumulator(str(log_dir))
    accumulator.Reload()
    return set(accumulator.Tags()["scalars"])


@pytest.mark.parametrize("baseline", [None, "value"])
def test_tensorboard_logging(tmp_path: pathlib.Path, baseline: str | None) -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", baseline=baseline, tensorboard_log=str(tmp_path), seed=0)
    model.learn(2000, log_interval=1)
    assert os.listdir(tmp_path) == ["REINFORCE_1"]
    tags = _tensorboard_tags(tmp_path / "REINFORCE_1")
    expected = {"train/policy_loss", "train/entropy_loss", "train/n_episodes", "rollout/ep_rew_mean", "time/fps"}
    if baseline == "value":
        expected |= {"train/value_loss", "train/explained_variance"}
    assert expected <= tags, expected - tags
    assert ("train/value_loss" in tags) == (baseline == "value")


def test_custom_logger_records(tmp_path: pathlib.Path) -> None:
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: gym.make("CartPole-v1")]), seed=0)
    model.set_logger(configure(str(tmp_path), ["csv"]))
    model.learn(1000, log_interval=1)
    header = (tmp_path / "progress.csv").read_text().splitlines()[0].split(",")
    assert {"train/policy_loss", "train/n_episodes", "time/fps", "train/learning_rate"} <= set(header)
