"""
The seed's agent (github.com/gabrielgarza/openai-gym-policy-gradient, TF1) as REINFORCE hyperparameters:
a 10-10 ReLU policy, one episode per update, standardized returns, Adam (eps 1e-8).

    model = REINFORCE(env="LunarLander-v3", **seed_hyperparams("LunarLander-v3"))
"""

from typing import Any

import torch as th
from torch import nn

__all__ = ["SEED_NORMAL_INIT", "SEED_SETUPS", "seed_hyperparams"]

#: Learning rate and discount of each of the seed's scripts, by environment family.
SEED_SETUPS: dict[str, dict[str, float]] = {
    "LunarLander": dict(learning_rate=0.02, gamma=0.99),
    "CartPole": dict(learning_rate=0.01, gamma=0.95),
    "MountainCar": dict(learning_rate=0.02, gamma=0.99),
    "Acrobot": dict(learning_rate=0.02, gamma=0.99),
    "CarRacing": dict(learning_rate=0.01, gamma=0.95),
}

#: ``(std, bias)`` init (weights ``N(0, std**2)``) of the ``tf.layers`` scripts; the others use Glorot-uniform.
SEED_NORMAL_INIT: dict[str, tuple[float, float]] = {"CarRacing": (0.3, 0.1)}


def seed_hyperparams(env_id: str = "LunarLander-v3") -> dict[str, Any]:
    """
    Constructor arguments of :class:`~sb3_reinforce.REINFORCE` that reproduce the seed's agent.

    :param env_id: The environment, to pick the seed script's learning rate and gamma (others: LunarLander's)
    :return: A new dict, safe to modify: ``REINFORCE(env=env, **seed_hyperparams(env_id))``
    """
    family = env_id.split("-")[0]
    setup = SEED_SETUPS.get(family, SEED_SETUPS["LunarLander"])
    init: dict[str, Any] = dict(normal_init=SEED_NORMAL_INIT[family]) if family in SEED_NORMAL_INIT else dict(xavier_init=True)
    return dict(
        policy="MlpPolicy",
        n_episodes=1,
        min_steps=0,
        baseline=None,
        normalize_returns=True,
        ent_coef=0.0,
        max_grad_norm=None,
        policy_kwargs=dict(
            net_arch=[10, 10],
            activation_fn=nn.ReLU,
            **init,
            optimizer_class=th.optim.Adam,
            optimizer_kwargs=dict(eps=1e-8),
        ),
        **setup,
    )
