"""
The seed's agent as a preset: the TF1 policy-gradient agent of the blog post this project grew from
(gabrielgarza/openai-gym-policy-gradient, see ``shared/seed/``).

    model = REINFORCE(env="LunarLander-v3", **seed_hyperparams("LunarLander-v3"))

builds exactly that agent: a 10-10 ReLU policy network with a softmax head and Glorot-uniform weights and
biases, no value network, Adam (TF1 defaults: eps 1e-8), one whole episode per update, returns discounted
then standardized, no gradient clipping, no entropy bonus. Learning rate and gamma are the seed script's
for that environment.
"""

from typing import Any

import torch as th
from torch import nn

__all__ = ["SEED_SETUPS", "seed_hyperparams"]

#: Learning rate and discount of each of the seed's scripts, by environment family.
SEED_SETUPS: dict[str, dict[str, float]] = {
    "LunarLander": dict(learning_rate=0.02, gamma=0.99),
    "CartPole": dict(learning_rate=0.01, gamma=0.95),
    "MountainCar": dict(learning_rate=0.02, gamma=0.99),
}


def seed_hyperparams(env_id: str = "LunarLander-v3") -> dict[str, Any]:
    """
    Constructor arguments of :class:`~sb3_reinforce.REINFORCE` that reproduce the seed's agent.

    :param env_id: The environment, to pick the seed script's learning rate and gamma
        (LunarLander: 0.02 / 0.99, CartPole: 0.01 / 0.95, MountainCar: 0.02 / 0.99). Other environments
        (the seed's repository also ran Acrobot and CarRacing without recording their values) get the
        blog post's LunarLander values.
    :return: A new dict, safe to modify: ``REINFORCE(env=env, **seed_hyperparams(env_id))``.
    """
    family = env_id.split("-")[0]
    setup = SEED_SETUPS.get(family, SEED_SETUPS["LunarLander"])
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
            xavier_init=True,
            optimizer_class=th.optim.Adam,
            optimizer_kwargs=dict(eps=1e-8),
        ),
        **setup,
    )
