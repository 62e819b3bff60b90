"""
Optuna search space of REINFORCE, for rl-baselines3-zoo's ``--optimize`` and for ``benchmarks/tune.py``.

- :func:`suggest_reinforce_params` asks the trial for every searched value (the raw values Optuna stores).
- :func:`zoo_entry` turns those raw values into an entry of a zoo hyperparameter file (plain YAML values:
  ``lin_<x>`` schedules, ``policy_kwargs`` as a Python string), which is what ``--trial-id`` loading
  (``convert_reinforce_params``) and a study's output config use.
- ``sample_reinforce_params`` is the zoo's sampler signature ``(trial, n_actions, n_envs, additional_args)``
  and returns constructor arguments of :class:`~sb3_reinforce.REINFORCE` (the same entry, parsed as the zoo
  parses a file). The number of environments and observation normalization are searched too: they are
  applied by :class:`sb3_reinforce.lab.zoo.exp_manager.ReinforceExperimentManager` before the trial's environments
  are built (observation normalization only where the config has no ``normalize`` of its own).

Every lever keeps the update Monte-Carlo policy gradient (one step per batch of whole episodes): batch size,
environments, observation normalization, learning-rate schedule, discount, network, entropy bonus, clipping,
return standardization and the baseline (none, a learned ``V(s)`` fitted by ``n_value_steps`` steps of its
own, or the leave-one-out mean).
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
#: The zoo's ``normalize`` value of a trial that normalizes observations: ``VecNormalize`` of the observations
#: only (the policy-gradient weights are standardized returns, ``normalize_returns``, or raw ones).
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
    Whether the trial normalizes observations (``VecNormalize``, observations only; asking again returns the
    same value).

    :param trial: The Optuna trial
    :return: The sampled value
    """
    return bool(trial.suggest_categorical("normalize_observations", [False, True]))


def suggest_reinforce_params(trial: optuna.Trial, search_normalization: bool = True) -> dict[str, Any]:
    """
    Ask the trial for every searched value. A leave-one-out baseline needs two episodes per batch: a trial
    that samples it with ``n_envs * n_episodes == 1`` is pruned.

    :param trial: The Optuna trial
    :param search_normalization: Whether to ask for ``normalize_observations`` (not where the config sets the
        zoo's ``normalize`` itself, which then stands for every trial)
    :return: The raw values, as ``trial.params`` stores them
    :raises optuna.TrialPruned: for a leave-one-out baseline with one episode per batch
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

    :param sampled_params: A trial's ``params`` (see :func:`suggest_reinforce_params`); ``lr_schedule``,
        ``n_value_steps`` and ``value_learning_rate`` may be missing (trials of older studies: constant, joint step)
    :return: Hyperparameters as in a zoo config (``n_envs`` included when it was sampled, ``normalize`` when
        observation normalization was sampled and is on)
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
    Parse zoo hyperparameters as rl_zoo3 parses a file: ``policy_kwargs`` strings evaluated with ``nn`` and
    ``th`` in scope, ``lin_<x>`` and numeric learning rates turned into schedules.

    :param hyperparams: Zoo hyperparameters (not modified)
    :return: A new dict, ready for the constructor (with the zoo keys it had, such as ``n_envs``)
    """
    from rl_zoo3.exp_manager import ExperimentManager

    parsed = dict(hyperparams)
    if isinstance(parsed.get("policy_kwargs"), str):
        parsed["policy_kwargs"] = eval(parsed["policy_kwargs"], {"nn": nn, "th": th, "dict": dict})
    return ExperimentManager._preprocess_schedules(parsed)


def convert_reinforce_params(sampled_params: dict[str, Any]) -> dict[str, Any]:
    """
    Convert the values Optuna stored for a trial into zoo hyperparameters (the zoo's ``--trial-id`` loading,
    which then parses them as it parses a file).

    :param sampled_params: A trial's ``params``
    :return: :func:`zoo_entry` of them
    """
    return zoo_entry(sampled_params)


def sample_reinforce_params(
    trial: optuna.Trial, n_actions: int, n_envs: int, additional_args: dict[str, Any]
) -> dict[str, Any]:
    """
    Sample REINFORCE hyperparameters (the zoo's sampler signature).

    :param trial: The Optuna trial
    :param n_actions: Size of the action vector (unused)
    :param n_envs: Number of environments the trial's training env has; must be the trial's ``n_envs``
        sample, which :class:`~sb3_reinforce.lab.zoo.exp_manager.ReinforceExperimentManager` applies
    :param additional_args: The zoo's extra arguments (unused)
    :return: Keyword arguments for :class:`~sb3_reinforce.REINFORCE` (without ``n_envs`` and ``normalize``,
        which set the env: the experiment manager suggests and applies ``normalize_observations`` itself)
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
