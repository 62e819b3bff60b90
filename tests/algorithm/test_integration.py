"""REINFORCE with SB3's VecEnvs, wrappers, evaluation and loggers."""

import os
import pathlib

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.envs import IdentityEnv, IdentityEnvBox
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


def _train_cartpole(vec_env_cls: type) -> tuple[dict[str, th.Tensor], dict[str, th.Tensor], list[float]]:
    """REINFORCE's weights before and after ``learn(1000)`` on two seeded CartPole envs, and its episodes' returns."""
    env = make_vec_env("CartPole-v1", n_envs=2, seed=0, vec_env_cls=vec_env_cls)
    try:
        model = REINFORCE("MlpPolicy", env, n_episodes=2, seed=0)
        initial = {name: value.clone() for name, value in model.policy.state_dict().items()}
        model.learn(1000)
        return initial, model.policy.state_dict(), [info["r"] for info in model.ep_info_buffer]
    finally:
        env.close()


def test_subproc_vec_env() -> None:
    # The envs in subprocesses give the same training as in this process: same episodes, same weights
    initial, subproc, subproc_returns = _train_cartpole(SubprocVecEnv)
    _, dummy, dummy_returns = _train_cartpole(DummyVecEnv)
    assert len(subproc_returns) > 0
    assert subproc_returns == dummy_returns
    assert subproc.keys() == dummy.keys()
    assert all(th.equal(subproc[name], dummy[name]) for name in dummy)
    assert not all(th.equal(subproc[name], initial[name]) for name in initial)  # the control: it trained


@pytest.mark.parametrize(
    "make_env", [lambda: IdentityEnv(4, ep_length=20), lambda: IdentityEnvBox(eps=0.5, ep_length=20)], ids=["Discrete", "Box"]
)
def test_evaluate_policy(make_env) -> None:
    # A known policy: with net_arch=[] the actor is one linear layer, set to the identity, whose mode (the largest
    # logit, the Gaussian's mean) is the action IdentityEnv rewards. Its samples often miss (logits 1 apart: p = 0.48;
    # std 1 against eps 0.5: p = 0.38 per step), so only the deterministic prediction scores on every step.
    model = REINFORCE("MlpPolicy", make_env(), policy_kwargs=dict(net_arch=[]), seed=0)
    action_net = model.policy.action_net
    with th.no_grad():
        action_net.weight.copy_(th.eye(*action_net.weight.shape))
        action_net.bias.zero_()

    rewards, lengths = evaluate_policy(model, make_env(), n_eval_episodes=3, return_episode_rewards=True, warn=False)
    assert rewards == [20.0] * 3
    assert lengths == [20] * 3
    sampled, _ = evaluate_policy(
        model, make_env(), n_eval_episodes=3, deterministic=False, return_episode_rewards=True, warn=False
    )
    assert max(sampled) < 20


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
