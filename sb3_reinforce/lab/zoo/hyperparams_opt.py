"""
Optuna search space of REINFORCE, for rl-baselines3-zoo's ``--optimize`` and ``benchmarks/tune.py``:
:func:`suggest_reinforce_params` asks the trial for the raw values, :func:`zoo_entry` turns them into a zoo yml entry
(``--trial-id`` loading, a study's output config), and :func:`sample_reinforce_params` is the zoo's sampler. ``n_envs``
and observation normalization are applied by :class:`~sb3_reinforce.lab.zoo.exp_manager.ReinforceExperimentManager`
before the environments are built.
"""

from typing import Any

import optuna
import torch as th
from torch import nn

from sb3_reinforce.reinforce.reinforce import check_hyperparameters

__all__ = [
    "ACTIVATIONS",
    "BASELINE_CHOICES",
    "NET_ARCHS",
    "NORMALIZE_OBSERVATIONS",
    "NORMALIZE_OBSERVATIONS_KWARGS",
    "N_ENVS_CHOICES",
    "N_VALUE_STEPS_CHOICES",
    "convert_reinforce_params",
    "parse_zoo_entry",
    "sample_reinforce_params",
    "suggest_n_envs",
    "suggest_normalize_observations",
    "suggest_reinforce_params",
    "zoo_entry",
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
#: Baselines searched: stored as strings ("none" for None).
BASELINE_CHOICES = ("none", "value", "loo")
#: Value-regression steps per batch searched with ``baseline="value"`` (0: one joint step with the policy).
N_VALUE_STEPS_CHOICES = (0, 5, 20, 80)
#: The zoo's ``normalize`` value of a trial that normalizes observations (not rewards).
NORMALIZE_OBSERVATIONS_KWARGS: dict[str, bool] = {"norm_obs": True, "norm_reward": False}
NORMALIZE_OBSERVATIONS = str(NORMALIZE_OBSERVATIONS_KWARGS)


def suggest_n_envs(trial: optuna.Trial) -> int:
    """
    The trial's number of parallel environments (asking again returns the same value).

    :param trial: The Optuna trial
    :return: One of ``N_ENVS_CHOICES``
    """
    return int(trial.suggest_categorical("n_envs", N_ENVS_CHOICES))


def suggest_normalize_observations(trial: optuna.Trial) -> bool:
    """
    Whether the trial normalizes observations with ``VecNormalize`` (asking again returns the same value).

    :param trial: The Optuna trial
    :return: The sampled value
    """
    return bool(trial.suggest_categorical("normalize_observations", [False, True]))


def suggest_reinforce_params(trial: optuna.Trial, search_normalization: bool = True) -> dict[str, Any]:
    """
    Ask the trial for every searched value.

    :param trial: The Optuna trial
    :param search_normalization: Whether to ask for ``normalize_observations`` (not where the config sets ``normalize``)
    :return: The raw values, as ``trial.params`` stores them
    :raises optuna.TrialPruned: for a leave-one-out baseline with one episode per batch (``n_envs * n_episodes == 1``)
    """
    suggest_n_envs(trial)
    if search_normalization:
        suggest_normalize_observations(trial)
    trial.suggest_float("learning_rate", 1e-4, 3e-2, log=True)
    trial.suggest_categorical("lr_schedule", ["constant", "linear"])
    trial.suggest_float("one_minus_gamma", 1e-3, 0.1, log=True)
    trial.suggest_categorical("n_episodes", [1, 2, 4, 8])  # per env: a batch of n_episodes * n_envs
    trial.suggest_categorical("net_arch", list(NET_ARCHS))
    trial.suggest_categorical("activation_fn", list(ACTIVATIONS))
    baseline = trial.suggest_categorical("baseline", BASELINE_CHOICES)
    if baseline == "value":
        if trial.suggest_categorical("n_value_steps", N_VALUE_STEPS_CHOICES) > 0:
            trial.suggest_float("value_learning_rate", 1e-4, 1e-2, log=True)
    trial.suggest_float("ent_coef", 1e-8, 0.05, log=True)
    trial.suggest_categorical("max_grad_norm", [0.0, 0.5, 1.0, 5.0])
    trial.suggest_categorical("normalize_returns", [True, False])
    params = dict(trial.params)
    if baseline == "loo" and params["n_envs"] * params["n_episodes"] < 2:
        raise optuna.TrialPruned("baseline='loo' needs n_envs * n_episodes >= 2")
    # Show the real value next to the sampled one in the study's reports
    trial.set_user_attr("gamma", 1.0 - params["one_minus_gamma"])
    return params


def zoo_entry(sampled_params: dict[str, Any]) -> dict[str, Any]:
    """
    The zoo hyperparameters of a trial, as they would be written in a zoo yml file.

    :param sampled_params: A trial's ``params`` (older studies lack ``lr_schedule`` and the value-network keys)
    :return: Hyperparameters as in a zoo config (with ``n_envs`` and ``normalize`` where sampled)
    """
    params = dict(sampled_params)
    learning_rate = float(params.pop("learning_rate"))
    linear = params.pop("lr_schedule", "constant") == "linear"
    net_arch = list(NET_ARCHS[params.pop("net_arch")])
    activation = ACTIVATIONS[params.pop("activation_fn")].__name__
    baseline = params.pop("baseline")
    hyperparams: dict[str, Any] = {
        "learning_rate": f"lin_{learning_rate!r}" if linear else learning_rate,
        "gamma": 1.0 - params.pop("one_minus_gamma"),
        "n_episodes": params.pop("n_episodes"),
        "baseline": None if baseline == "none" else baseline,
        "ent_coef": params.pop("ent_coef"),
        "normalize_returns": params.pop("normalize_returns"),
        "policy_kwargs": f"dict(net_arch={net_arch}, activation_fn=nn.{activation})",
    }
    n_value_steps = params.pop("n_value_steps", 0)
    if n_value_steps:
        hyperparams["n_value_steps"] = n_value_steps
        hyperparams["value_learning_rate"] = params.pop("value_learning_rate")
    max_grad_norm = params.pop("max_grad_norm")
    hyperparams["max_grad_norm"] = None if max_grad_norm == 0 else max_grad_norm
    if "n_envs" in params:
        hyperparams["n_envs"] = params.pop("n_envs")
    if params.pop("normalize_observations", False):
        hyperparams["normalize"] = NORMALIZE_OBSERVATIONS
    if params:
        raise ValueError(f"Unknown REINFORCE search parameters {sorted(params)}")
    return hyperparams


def parse_zoo_entry(hyperparams: dict[str, Any]) -> dict[str, Any]:
    """
    Parse zoo hyperparameters as rl_zoo3 parses a file (``policy_kwargs`` evaluated, learning-rate schedules built).

    :param hyperparams: Zoo hyperparameters (not modified)
    :return: A new dict, ready for the constructor (with the zoo keys it had, such as ``n_envs``)
    """
    from rl_zoo3.exp_manager import ExperimentManager

    parsed = dict(hyperparams)
    if isinstance(parsed.get("policy_kwargs"), str):
        parsed["policy_kwargs"] = eval(parsed["policy_kwargs"], {"nn": nn, "th": th, "dict": dict})
    return ExperimentManager._preprocess_schedules(parsed)


#: Converts a trial's stored values into zoo hyperparameters (the zoo's ``--trial-id`` loading): :func:`zoo_entry`.
convert_reinforce_params = zoo_entry


def sample_reinforce_params(
    trial: optuna.Trial, n_actions: int, n_envs: int, additional_args: dict[str, Any]
) -> dict[str, Any]:
    """
    Sample REINFORCE hyperparameters (the zoo's sampler signature).

    :param trial: The Optuna trial
    :param n_actions: Size of the action vector (unused)
    :param n_envs: Number of environments of the trial's training env; must equal the trial's ``n_envs`` sample
    :param additional_args: The zoo's extra arguments (unused)
    :return: Keyword arguments for :class:`~sb3_reinforce.REINFORCE` (without ``n_envs`` and ``normalize``)
    """
    sampled_n_envs = suggest_n_envs(trial)
    if sampled_n_envs != n_envs:
        raise RuntimeError(
            f"The trial sampled n_envs={sampled_n_envs} but its environment has {n_envs}: run the search through "
            "`python -m sb3_reinforce.lab.zoo train --algo reinforce --optimize ...`, which applies the sampled n_envs."
        )
    kwargs = parse_zoo_entry(zoo_entry(suggest_reinforce_params(trial, search_normalization=False)))
    del kwargs["n_envs"]
    kwargs.pop("normalize", None)
    check_hyperparameters(kwargs)  # each searched name is one of REINFORCE's hyperparameters, each value valid
    return kwargs
