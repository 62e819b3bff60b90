"""The seed's agent as a preset builds exactly the seed's network and optimizer."""

import math

import pytest
import torch as th
from torch import nn

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.seed.presets import seed_hyperparams


@pytest.mark.parametrize(
    "env_id, obs_dim, n_actions, lr, gamma",
    [("LunarLander-v3", 8, 4, 0.02, 0.99), ("CartPole-v1", 4, 2, 0.01, 0.95), ("MountainCar-v0", 2, 3, 0.02, 0.99)],
)
def test_seed_preset_network(env_id: str, obs_dim: int, n_actions: int, lr: float, gamma: float) -> None:
    model = REINFORCE(env=env_id, **seed_hyperparams(env_id))
    policy = model.policy
    layers = [type(m) for m in policy.mlp_extractor.policy_net]
    assert layers == [nn.Linear, nn.ReLU, nn.Linear, nn.ReLU]
    linears = [m for m in policy.mlp_extractor.policy_net if isinstance(m, nn.Linear)] + [policy.action_net]
    assert [(m.in_features, m.out_features) for m in linears] == [(obs_dim, 10), (10, 10), (10, n_actions)]
    assert not hasattr(policy, "value_net"), "no value head"
    assert len(policy.mlp_extractor.value_net) == 0
    n_params = sum(p.numel() for p in policy.parameters())
    assert n_params == (obs_dim * 10 + 10) + (10 * 10 + 10) + (10 * n_actions + n_actions)
    # Glorot-uniform weights and biases (TF1 xavier_initializer): biases are not zero and within bounds
    for m in linears:
        bound = math.sqrt(6 / (m.in_features + m.out_features))
        assert m.weight.abs().max() <= bound
        assert m.bias.abs().max() <= math.sqrt(6 / (m.out_features + 1)) and m.bias.abs().sum() > 0
    optimizer = policy.optimizer
    assert isinstance(optimizer, th.optim.Adam)
    assert optimizer.param_groups[0]["lr"] == lr and optimizer.param_groups[0]["eps"] == 1e-8
    assert sum(p.numel() for g in optimizer.param_groups for p in g["params"]) == n_params
    assert model.gamma == gamma and model.n_episodes == 1 and model.baseline is None
    assert model.normalize_returns and model.max_grad_norm is None and model.ent_coef == 0.0
    # the softmax head: a categorical distribution over the actions
    dist = policy.get_distribution(th.zeros(1, obs_dim))
    assert th.allclose(dist.distribution.probs.sum(), th.tensor(1.0))


def test_seed_preset_trains_and_is_a_fresh_dict() -> None:
    kwargs = seed_hyperparams("CartPole-v1")
    kwargs["policy_kwargs"]["net_arch"] = [1]
    assert seed_hyperparams("CartPole-v1")["policy_kwargs"]["net_arch"] == [10, 10]
    REINFORCE(env="CartPole-v1", **seed_hyperparams("CartPole-v1")).learn(300)
