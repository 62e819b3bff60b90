"""As SB3's tests/test_deterministic.py: the same seed gives the same results."""

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env

from sb3_reinforce import REINFORCE


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize("env_id, n_envs", [("CartPole-v1", 1), ("Pendulum-v1", 2)])
def test_same_seed_same_result(env_id: str, n_envs: int, baseline: str | None) -> None:
    results = []
    for _ in range(2):
        env = make_vec_env(env_id, n_envs=n_envs, seed=3)
        model = REINFORCE("MlpPolicy", env, baseline=baseline, seed=3).learn(1500)
        obs = env.reset()
        actions = [model.predict(obs, deterministic=False)[0] for _ in range(3)]
        results.append(([p.detach().clone() for p in model.policy.parameters()], actions, list(model.ep_info_buffer)))
    (params_a, actions_a, episodes_a), (params_b, actions_b, episodes_b) = results
    assert all(th.equal(a, b) for a, b in zip(params_a, params_b, strict=True))
    for a, b in zip(actions_a, actions_b, strict=True):
        np.testing.assert_array_equal(a, b)
    assert [e["r"] for e in episodes_a] == [e["r"] for e in episodes_b]


def test_different_seeds_differ() -> None:
    a = REINFORCE("MlpPolicy", "CartPole-v1", seed=1).learn(500)
    b = REINFORCE("MlpPolicy", "CartPole-v1", seed=2).learn(500)
    assert not all(th.equal(x, y) for x, y in zip(a.policy.parameters(), b.policy.parameters(), strict=True))
