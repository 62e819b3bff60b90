"""As SB3's tests/test_callbacks.py: REINFORCE drives SB3's callbacks like A2C/PPO do."""

import os
import pathlib

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.callbacks import (
    BaseCallback,
    CallbackList,
    CheckpointCallback,
    EvalCallback,
    StopTrainingOnMaxEpisodes,
    StopTrainingOnRewardThreshold,
)
from stable_baselines3.common.env_util import make_vec_env

from sb3_reinforce import REINFORCE


class LocalsSpy(BaseCallback):
    def __init__(self) -> None:
        super().__init__()
        self.calls = {"rollout_start": 0, "rollout_end": 0, "step": 0}

    def _on_rollout_start(self) -> None:
        self.calls["rollout_start"] += 1

    def _on_rollout_end(self) -> None:
        self.calls["rollout_end"] += 1

    def _on_step(self) -> bool:
        self.calls["step"] += 1
        for key in ("new_obs", "rewards", "dones", "infos", "actions"):
            assert key in self.locals, key
        assert len(self.locals["dones"]) == self.training_env.num_envs
        assert isinstance(self.locals["new_obs"], np.ndarray)
        return True


def test_callback_list(tmp_path: pathlib.Path) -> None:
    eval_env = gym.make("CartPole-v1")
    stop = StopTrainingOnRewardThreshold(reward_threshold=-np.inf, verbose=1)  # stops at the first evaluation
    eval_callback = EvalCallback(
        eval_env, callback_on_new_best=stop, best_model_save_path=str(tmp_path), log_path=str(tmp_path), eval_freq=100
    )
    checkpoint = CheckpointCallback(save_freq=100, save_path=str(tmp_path / "ckpt"), name_prefix="reinforce")
    spy = LocalsSpy()
    model = REINFORCE("MlpPolicy", make_vec_env("CartPole-v1", n_envs=2, seed=0), seed=0)
    model.learn(2_000, callback=CallbackList([checkpoint, eval_callback, spy]))

    assert model.num_timesteps <= 2 * 100 + 2, "StopTrainingOnRewardThreshold stopped training at the first evaluation"
    assert os.path.exists(tmp_path / "best_model.zip") and os.path.exists(tmp_path / "evaluations.npz")
    assert any(name.startswith("reinforce_") for name in os.listdir(tmp_path / "ckpt"))
    REINFORCE.load(tmp_path / "best_model.zip")
    assert spy.calls["step"] == model.num_timesteps // 2
    assert spy.calls["rollout_start"] >= 1


def test_stop_on_max_episodes() -> None:
    spy = LocalsSpy()
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0)
    model.learn(100_000, callback=[StopTrainingOnMaxEpisodes(max_episodes=7), spy])
    assert len(model.ep_info_buffer) == 7
    assert spy.calls["rollout_end"] == 6, "six whole batches trained, the seventh episode ended the run"


def test_stop_inside_rollout_keeps_experience() -> None:
    """A callback that stops mid-rollout loses no transition: learning continues from the same buffer."""

    class StopAt(BaseCallback):
        def _on_step(self) -> bool:
            return self.num_timesteps < 30

    model = REINFORCE("MlpPolicy", "CartPole-v1", n_episodes=5, seed=0)
    model.learn(1000, callback=StopAt())
    stored = model.rollout_buffer.size()
    assert stored == 30 and model.num_timesteps == 30
    model.learn(30, reset_num_timesteps=False)
    assert model.num_timesteps > 30


def test_progress_bar(capsys: pytest.CaptureFixture[str]) -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0).learn(300, progress_bar=True)
    assert model.num_timesteps >= 300
    assert f"{model.num_timesteps}/300" in capsys.readouterr().out  # rich's bar, ended at the steps done
