"""
Optuna search space of REINFORCE for rl-baselines3-zoo's ``--optimize``.

``sample_reinforce_params`` is the zoo's sampler signature ``(trial, n_actions, n_envs, additional_args)``
and returns constructor arguments of :class:`~sb3_reinforce.REINFORCE`. ``convert_reinforce_params`` turns
the raw values Optuna stores for a trial (``study.trials[i].params``) into zoo hyperparameters, which is what
the zoo's ``--trial-id`` loading uses. The number of environments is searched too: it is applied by
:class:`sb3_reinforce.zoo.exp_manager.ReinforceExperimentManager` before the trial's environments are built.
"""

from typing import Any

import optuna
from torch import nn

__all__ = [
    "ACTIVATIONS",
    "NET_ARCHS",
    "N_ENVS_CHOICES",
    "convert_reinforce_params",
    "sample_reinforce_params",
    "suggest_n_envs",
]

#: Hidden layers of the policy (and of the value network, with a baseline). "seed": the seed's 10-10.
NET_ARCHS: dict[str, list[int]] = {
    "seed": [10, 10],
    "tiny": [32],
    "small": [64, 64],
    "medium": [256, 256],
}
ACTIVATIONS: dict[str, type[nn.Module]] = {"tanh": nn.Tanh, "relu": nn.ReLU}
#: Numbers of parallel environments searched (``n_envs``).
N_ENVS_CHOICES = (1, 2, 4, 8)


def suggest_n_envs(trial: optuna.Trial) -> int:
    """
    The trial's number of parallel environments (asking again returns the same value).

    :param trial: The Optuna trial
    :return: One of ``N_ENVS_CHOICES``
    """
    return int(trial.suggest_categorical("n_envs", N_ENVS_CHOICES))


def convert_reinforce_params(sampled_params: dict[str, Any]) -> dict[str, Any]:
    """
    Convert the values Optuna sampled (and stores) into zoo hyperparameters for REINFORCE.

    :param sampled_params: A trial's ``params``: ``learning_rate``, ``one_minus_gamma``, ``n_episodes``,
        ``net_arch`` (a key of ``NET_ARCHS``), ``activation_fn`` (a key of ``ACTIVATIONS``), ``baseline``
        (``"none"`` or ``"value"``), ``ent_coef``, ``max_grad_norm`` (0 means no clipping),
        ``normalize_returns`` and optionally ``n_envs``
    :return: Hyperparameters as in a zoo config (``n_envs`` included when it was sampled)
    """
    params = dict(sampled_params)
    hyperparams: dict[str, Any] = {
        "learning_rate": params.pop("learning_rate"),
        "gamma": 1.0 - params.pop("one_minus_gamma"),
        "n_episodes": params.pop("n_episodes"),
        "baseline": None if params.pop("baseline") == "none" else "value",
        "ent_coef": params.pop("ent_coef"),
        "normalize_returns": params.pop("normalize_returns"),
        "policy_kwargs": dict(
            net_arch=list(NET_ARCHS[params.pop("net_arch")]),
            activation_fn=ACTIVATIONS[params.pop("activation_fn")],
        ),
    }
    max_grad_norm = params.pop("max_grad_norm")
    hyperparams["max_grad_norm"] = None if max_grad_norm == 0 else max_grad_norm
    if "n_envs" in params:
        hyperparams["n_envs"] = params.pop("n_envs")
    if params:
        raise ValueError(f"Unknown REINFORCE search parameters {sorted(params)}")
    return hyperparams


def sample_reinforce_params(
    trial: optuna.Trial, n_actions: int, n_envs: int, additional_args: dict[str, Any]
) -> dict[str, Any]:
    """
    Sample REINFORCE hyperparameters (the zoo's sampler signature).

    :param trial: The Optuna trial
    :param n_actions: Size of the action vector (unused)
    :param n_envs: Number of environments the trial's training env has; must be the trial's ``n_envs``
        sample, which :class:`~sb3_reinforce.zoo.exp_manager.ReinforceExperimentManager` applies
    :param additional_args: The zoo's extra arguments (unused)
    :return: Keyword arguments for :class:`~sb3_reinforce.REINFORCE` (without ``n_envs``, which sets the env)
    """
    sampled_n_envs = suggest_n_envs(trial)
    if sampled_n_envs != n_envs:
        raise RuntimeError(
            f"The trial sampled n_envs={sampled_n_envs} but its environment has {n_envs}: run the search through "
            "`python -m sb3_reinforce.zoo train --algo reinforce --optimize ...`, which applies the sampled n_envs."
        )
    sampled: dict[str, Any] = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 3e-2, log=True),
        "one_minus_gamma": trial.suggest_float("one_minus_gamma", 1e-3, 0.1, log=True),
        "n_episodes": trial.suggest_categorical("n_episodes", [1, 2, 4, 8]),  # per env: batch of n_episodes * n_envs
        "net_arch": trial.suggest_categorical("net_arch", list(NET_ARCHS)),
        "activation_fn": trial.suggest_categorical("activation_fn", list(ACTIVATIONS)),
        "baseline": trial.suggest_categorical("baseline", ["none", "value"]),
        "ent_coef": trial.suggest_float("ent_coef", 1e-8, 0.05, log=True),
        "max_grad_norm": trial.suggest_categorical("max_grad_norm", [0.0, 0.5, 1.0, 5.0]),
        "normalize_returns": trial.suggest_categorical("normalize_returns", [True, False]),
    }
    # Show the real value next to the sampled one in the study's reports
    trial.set_user_attr("gamma", 1.0 - sampled["one_minus_gamma"])
    return convert_reinforce_params(sampled)
