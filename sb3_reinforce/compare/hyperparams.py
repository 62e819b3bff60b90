"""
Hyperparameters of each algorithm in the comparison, in rl-baselines3-zoo's yml format: REINFORCE's from
this repository's ``zoo_configs/reinforce.yml`` (or ``--reinforce-config``), PPO's and A2C's from the
*installed* rl_zoo3 package (``rl_zoo3/hyperparams/{ppo,a2c}.yml``), parsed as the zoo parses them.
"""

import importlib.util
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch as th
import yaml
from torch import nn

__all__ = ["ALGOS", "REINFORCE_CONFIG", "ZooConfig", "ZooConfigError", "default_config_path", "load_zoo_config"]

#: Algorithms the comparison knows, by lower-case name.
ALGOS = ("reinforce", "ppo", "a2c")

#: REINFORCE's hyperparameter file in a source checkout (the repository's ``zoo_configs/``).
REINFORCE_CONFIG = Path(__file__).resolve().parents[2] / "zoo_configs" / "reinforce.yml"

# Keys that change how the zoo builds the env or training loop, that this comparison does not implement:
# refused instead of silently ignored.
_UNSUPPORTED_KEYS = ("frame_stack", "env_wrapper", "vec_env_wrapper", "callback", "monitor_kwargs", "env_kwargs")


class ZooConfigError(ValueError):
    """An algorithm has no (usable) hyperparameters for the environment."""


@dataclass
class ZooConfig:
    """
    One algorithm's zoo entry for one environment, split as the zoo splits it.

    :param algo: Lower-case algorithm name
    :param env_id: The environment id
    :param source: The yml file it was read from
    :param n_envs: Number of parallel training environments
    :param n_timesteps: The zoo's training budget
    :param normalize: Whether to wrap the training env in ``VecNormalize``
    :param normalize_kwargs: Keyword arguments of ``VecNormalize`` (the zoo sets ``gamma`` to the algorithm's)
    :param model_kwargs: Keyword arguments of the algorithm's constructor (policy included; schedules and
        ``policy_kwargs`` already converted to Python objects)
    :param raw: The entry as written in the file (for the record)
    """

    algo: str
    env_id: str
    source: Path
    n_envs: int
    n_timesteps: int
    normalize: bool
    normalize_kwargs: dict[str, Any]
    model_kwargs: dict[str, Any]
    raw: dict[str, Any] = field(default_factory=dict)


def default_config_path(algo: str) -> Path:
    """
    Where ``algo``'s hyperparameters are read from by default.

    :param algo: ``"reinforce"``, ``"ppo"`` or ``"a2c"``
    :return: The yml file
    """
    if algo == "reinforce":
        return REINFORCE_CONFIG
    if algo not in ALGOS:
        raise ZooConfigError(f"Unknown algorithm {algo!r}: choose among {', '.join(ALGOS)}")
    spec = importlib.util.find_spec("rl_zoo3")
    if spec is None or spec.origin is None:
        raise ZooConfigError(
            f"rl_zoo3 is not installed: it provides {algo.upper()}'s tuned hyperparameters (pip install rl_zoo3)"
        )
    return Path(spec.origin).parent / "hyperparams" / f"{algo}.yml"


def _preprocess_schedules(hyperparams: dict[str, Any]) -> dict[str, Any]:
    # rl_zoo3's own parsing ("lin_0.001" -> linear schedule, numbers -> constant schedules)
    from rl_zoo3.exp_manager import ExperimentManager

    return ExperimentManager._preprocess_schedules(hyperparams)


def load_zoo_config(algo: str, env_id: str, path: Path | None = None) -> ZooConfig:
    """
    Read ``algo``'s entry for ``env_id`` from a zoo hyperparameter file and parse it as rl_zoo3 does:
    ``!!float`` numbers, ``lin_<x>`` schedules, ``policy_kwargs`` / ``normalize`` given as Python strings
    (evaluated with ``nn`` and ``th`` in scope), ``n_envs``, ``n_timesteps`` and ``normalize`` taken out of
    the constructor arguments.

    :param algo: ``"reinforce"``, ``"ppo"`` or ``"a2c"``
    :param env_id: The environment id (the file's top-level key)
    :param path: The yml file (default: :func:`default_config_path`)
    :return: The parsed entry
    :raises ZooConfigError: if the file is missing, has no entry for ``env_id``, or uses a key this
        comparison does not implement
    """
    path = default_config_path(algo) if path is None else Path(path)
    if not path.is_file():
        raise ZooConfigError(f"{algo.upper()} hyperparameter file not found: {path}")
    try:
        with path.open() as f:
            entries = yaml.load(f, Loader=yaml.UnsafeLoader)  # as rl_zoo3 (!!float, python tags)
    except yaml.YAMLError as error:
        raise ZooConfigError(f"{algo.upper()} hyperparameter file {path} is not valid YAML: {error}") from error
    if not isinstance(entries, dict) or env_id not in entries:
        known = ", ".join(sorted(entries)) if isinstance(entries, dict) else "none"
        raise ZooConfigError(
            f"{algo.upper()} has no hyperparameters for {env_id} in {path} (entries: {known}). "
            + ("Add one, or pass --reinforce-config FILE." if algo == "reinforce" else "")
        )
    raw = dict(entries[env_id])
    unsupported = [key for key in _UNSUPPORTED_KEYS if key in raw]
    if unsupported:
        raise ZooConfigError(f"{algo.upper()}'s entry for {env_id} in {path} uses {unsupported}: not supported by compare")
    hyperparams = dict(raw)
    n_envs = int(hyperparams.pop("n_envs", 1))
    n_timesteps = int(hyperparams.pop("n_timesteps"))
    normalize: Any = hyperparams.pop("normalize", False)
    normalize_kwargs: dict[str, Any] = {}
    if isinstance(normalize, str):
        normalize_kwargs = eval(normalize)
        normalize = True
    elif isinstance(normalize, dict):
        normalize_kwargs, normalize = dict(normalize), True
    if normalize and "gamma" in hyperparams:
        normalize_kwargs["gamma"] = hyperparams["gamma"]
    if isinstance(hyperparams.get("policy_kwargs"), str):
        hyperparams["policy_kwargs"] = eval(hyperparams["policy_kwargs"], {"nn": nn, "th": th, "dict": dict})
    hyperparams = _preprocess_schedules(hyperparams)
    return ZooConfig(
        algo=algo,
        env_id=env_id,
        source=path,
        n_envs=n_envs,
        n_timesteps=n_timesteps,
        normalize=bool(normalize),
        normalize_kwargs=normalize_kwargs,
        model_kwargs=hyperparams,
        raw=raw,
    )
