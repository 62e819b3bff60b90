"""
The seed's agent as a preset: the TF1 policy-gradient agent of the blog post this project grew from
(github.com/gabrielgarza/openai-gym-policy-gradient).

    model = REINFORCE(env="LunarLander-v3", **seed_hyperparams("LunarLander-v3"))

builds exactly that agent: a 10-10 ReLU policy network with a softmax head and Glorot-uniform weights and
biases, no value network, Adam (TF1 defaults: eps 1e-8), one whole episode per update, returns discounted
then standardized, no gradient clipping, no entropy bonus. Learning rate and gamma are the seed script's
for that environment. The seed's CarRacing script used its ``tf.layers`` variant of the same network
(weights ``N(0, 0.3**2)``, biases 0.1) on pixels it preprocessed itself: the environment side of the seed's
scripts (time limits, pixels, actions) is :func:`sb3_reinforce.lab.seed.envs.make_seed_env`.
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

#: The scripts built on the seed's ``tf.layers`` network (``policy_gradient_layers.py``): ``(std, bias)`` of its
#: initialization, weights ``N(0, std**2)`` and constant biases. The others use Glorot-uniform weights and biases.
SEED_NORMAL_INIT: dict[str, tuple[float, float]] = {"CarRacing": (0.3, 0.1)}


def seed_hyperparams(env_id: str = "LunarLander-v3") -> dict[str, Any]:
    """
    Constructor arguments of :class:`~sb3_reinforce.REINFORCE` that reproduce the seed's agent.

    :param env_id: The environment, to pick the seed script's learning rate and gamma
        (LunarLander, MountainCar, Acrobot: 0.02 / 0.99, CartPole: 0.01 / 0.95, CarRacing: 0.01 / 0.95, with
        the ``tf.layers`` initialization). Other environments get the blog post's LunarLander values.
    :return: A new dict, safe to modify: ``REINFORCE(env=env, **seed_hyperparams(env_id))``.
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
