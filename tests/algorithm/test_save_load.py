"""As SB3's tests/test_save_load.py: round trips, parameters, continued training."""

import pathlib

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.envs import IdentityEnv, IdentityEnvBox
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE


def _params_equal(a: dict, b: dict) -> bool:
    return all(th.equal(a[k], b[k]) for k in a) and a.keys() == b.keys()


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize("make_env", [lambda: IdentityEnv(4), lambda: IdentityEnvBox(eps=0.5)])
def test_save_load_roundtrip(tmp_path: pathlib.Path, baseline: str | None, make_env) -> None:
    env = DummyVecEnv([make_env])
    model = REINFORCE("MlpPolicy", env, baseline=baseline, n_episodes=2, gamma=0.7, seed=0).learn(500)
    observations = np.stack([env.observation_space.sample() for _ in range(20)])
    actions_before, _ = model.predict(observations, deterministic=True)
    params_before = {k: v.clone() for k, v in model.policy.state_dict().items()}
    optimizer_before = model.policy.optimizer.state_dict()

    model.save(tmp_path / "model.zip")
    del model
    model = REINFORCE.load(tmp_path / "model.zip", env=env)

    assert model.baseline == baseline and model.n_episodes == 2 and model.gamma == 0.7
    assert _params_equal(params_before, model.policy.state_dict())
    assert (model.policy.__dict__.get("value_head") is True) == (baseline == "value")
    np.testing.assert_array_equal(model.predict(observations, deterministic=True)[0], actions_before)
    state = model.policy.optimizer.state_dict()["state"]
    assert all(th.equal(state[k]["exp_avg"], optimizer_before["state"][k]["exp_avg"]) for k in state)

    # training continues after load
    timesteps = model.num_timesteps
    model.learn(300, reset_num_timesteps=False)
    assert model.num_timesteps >= timesteps + 300
    assert not _params_equal(params_before, model.policy.state_dict())


def test_get_set_parameters() -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0)
    params = model.get_parameters()
    assert set(params) == {"policy", "policy.optimizer"}
    other = REINFORCE("MlpPolicy", "CartPole-v1", seed=1)
    assert not _params_equal(params["policy"], other.get_parameters()["policy"])
    other.set_parameters(params, exact_match=True)
    assert _params_equal(params["policy"], other.get_parameters()["policy"])
    with pytest.raises(RuntimeError, match="not_a_param"):
        other.set_parameters({"policy": {"not_a_param": th.zeros(1)}, "policy.optimizer": params["policy.optimizer"]})


@pytest.mark.parametrize("reset_num_timesteps", [False, True])
def test_set_env_discards_running_episodes(reset_num_timesteps: bool) -> None:
    # Episodes of 3 and 5 steps: the first batch (one finished episode per env) ends at step 5, with the first env
    # 2 steps into its second episode, which stays in the buffer for the next batch
    old_env = DummyVecEnv([lambda: IdentityEnv(4, ep_length=3), lambda: IdentityEnv(4, ep_length=5)])
    model = REINFORCE("MlpPolicy", old_env, n_episodes=1, seed=0).learn(1)
    assert model.rollout_buffer.env_steps.tolist() == [2, 0]

    model.set_env(DummyVecEnv([lambda: IdentityEnv(4, ep_length=4)] * 2))
    model.learn(1, reset_num_timesteps=reset_num_timesteps)
    # The next batch is the new envs' first episodes, 4 steps each: the old env's 2 steps are not joined to one of them
    assert model.rollout_buffer.episode_lengths.tolist() == [4, 4]
    assert model.rollout_buffer.size() == 0


def test_load_without_env_predicts(tmp_path: pathlib.Path) -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0).learn(200)
    model.save(tmp_path / "m")
    loaded = REINFORCE.load(tmp_path / "m")
    obs = np.zeros((3, 4), dtype=np.float32)
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0])
    assert loaded.get_env() is None
