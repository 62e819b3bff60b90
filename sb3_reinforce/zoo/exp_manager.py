"""
rl_zoo3's ``ExperimentManager``, with what REINFORCE needs on top.

- ``--algo reinforce`` reads ``zoo_configs/reinforce.yml`` unless ``-conf/--conf-file`` is given.
- Config errors are found before anything is built: a missing file or env entry, a key the algorithm's
  constructor does not accept, or (for REINFORCE) an invalid value raise :class:`ZooUsageError` with the
  file, the env id and the allowed keys or values.
- ``--optimize`` applies the trial's sampled ``n_envs``, records which worker (host:pid) ran each trial,
  and prunes trials whose hyperparameters make REINFORCE fail (non-finite loss, a rollout too long)
  instead of ending the whole study.
"""

import inspect
import os
import socket
from pathlib import Path
from typing import Any

import optuna
import yaml
from rl_zoo3.exp_manager import ExperimentManager
from rl_zoo3.utils import ALGOS
from stable_baselines3.common.callbacks import BaseCallback

from sb3_reinforce.buffers import RolloutLimitError
from sb3_reinforce.reinforce import NonFiniteError
from sb3_reinforce.validation import validate_hyperparameters
from sb3_reinforce.zoo.configs import config_path
from sb3_reinforce.zoo.hyperparams_opt import suggest_n_envs

__all__ = ["ALGO_NAME", "ReinforceExperimentManager", "ZooUsageError"]

#: The name of REINFORCE in the zoo's ``--algo``.
ALGO_NAME = "reinforce"

# Keys of a zoo config that the zoo itself consumes (they never reach the algorithm's constructor).
_ZOO_KEYS = {"env", "tensorboard_log", "seed", "verbose", "device"}


class ZooUsageError(ValueError):
    """A command-line argument or hyperparameter file the zoo cannot use; the message says what to fix."""


def accepted_arguments(algo_class: type) -> set[str] | None:
    """
    Keyword arguments an algorithm's constructor accepts.

    :param algo_class: The algorithm class
    :return: Their names, or None when the constructor takes ``**kwargs`` (anything is accepted)
    """
    parameters = inspect.signature(algo_class).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return None
    return set(parameters)


def check_reinforce_values(hyperparams: dict[str, Any]) -> None:
    """
    Run REINFORCE's argument checks on a config's values, constructor defaults filling the gaps.

    :param hyperparams: Constructor keyword arguments (as the zoo passes them)
    """
    from sb3_reinforce import REINFORCE

    defaults = {name: p.default for name, p in inspect.signature(REINFORCE).parameters.items() if p.default is not p.empty}
    names = inspect.signature(validate_hyperparameters).parameters
    validate_hyperparameters(**{name: hyperparams.get(name, defaults[name]) for name in names})


class ReinforceExperimentManager(ExperimentManager):
    """
    rl_zoo3's ``ExperimentManager`` (same arguments) with REINFORCE's default config, early config checks
    and REINFORCE-aware hyperparameter optimization (see the module docstring).
    """

    def __init__(self, args: Any, algo: str, *positional: Any, config: str | None = None, **kwargs: Any) -> None:
        if config is None and algo == ALGO_NAME:
            config = str(config_path("reinforce"))
        if config is not None and config.endswith((".yml", ".yaml")) and not os.path.isfile(config):
            raise ZooUsageError(f"Hyperparameter file {config} (-conf/--conf-file) does not exist")
        kwargs["config"] = config
        super().__init__(args, algo, *positional, **kwargs)

    def read_hyperparameters(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """
        Read the env's entry of the config file, after checking that the file has one.

        :return: The hyperparameters and the copy the zoo saves with the run
        """
        if self.config.endswith((".yml", ".yaml")):
            try:
                entries = yaml.safe_load(Path(self.config).read_text())
            except yaml.YAMLError as error:
                raise ZooUsageError(f"{self.config} is not valid YAML: {error}") from error
            if not isinstance(entries, dict):
                raise ZooUsageError(f"{self.config} must map env ids to hyperparameters")
            env_id = self.env_name.gym_id
            if env_id not in entries and "default" not in entries and not (self._is_atari and "atari" in entries):
                raise ZooUsageError(
                    f"{self.config} has no entry for {env_id} (it has: {', '.join(sorted(entries))}). "
                    "Add one, or pass another file with -conf/--conf-file."
                )
        return super().read_hyperparameters()

    def _preprocess_hyperparams(self, hyperparams: dict[str, Any]) -> tuple[dict[str, Any], Any, list[BaseCallback], Any]:
        processed, env_wrapper, callbacks, vec_env_wrapper = super()._preprocess_hyperparams(hyperparams)
        where = f"{self.config} [{self.env_name.gym_id}]"
        if self.custom_hyperparams:
            where += f" with -params {' '.join(sorted(self.custom_hyperparams))}"
        algo_class = ALGOS[self.algo]
        accepted = accepted_arguments(algo_class)
        reserved = sorted(set(processed) & _ZOO_KEYS)
        if reserved:
            raise ZooUsageError(
                f"{where}: {', '.join(map(repr, reserved))} cannot be set in a config: the zoo sets them "
                "(use --seed, --device, --verbose, -tb/--tensorboard-log)"
            )
        if accepted is not None:
            # noise_type/noise_std become an action noise object after this step (off-policy algorithms)
            unknown = sorted(set(processed) - accepted - {"noise_type", "noise_std"})
            if unknown:
                allowed = sorted(accepted - _ZOO_KEYS - {"_init_setup_model"})
                raise ZooUsageError(
                    f"{where}: {algo_class.__name__} does not accept {', '.join(map(repr, unknown))}. "
                    f"Its arguments: {', '.join(allowed)}; "
                    "the zoo's own keys: n_timesteps, n_envs, normalize, frame_stack, env_wrapper, vec_env_wrapper, "
                    "env_kwargs, monitor_kwargs, callback, noise_type, noise_std."
                )
        if self.algo == ALGO_NAME:
            try:
                check_reinforce_values(processed)
            except ValueError as error:
                raise ZooUsageError(f"{where}: {error}") from error
        return processed, env_wrapper, callbacks, vec_env_wrapper

    def objective(self, trial: optuna.Trial) -> float:
        """
        Train and evaluate one trial (rl_zoo3's objective). For REINFORCE, the trial's ``n_envs`` sample
        sets the number of environments, and a failure caused by the sampled hyperparameters prunes the trial.

        :param trial: The Optuna trial
        :return: The last mean evaluation reward
        """
        trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
        if self.algo != ALGO_NAME:
            return super().objective(trial)
        config_n_envs = self.n_envs
        self.n_envs = suggest_n_envs(trial)
        try:
            return super().objective(trial)
        except (NonFiniteError, RolloutLimitError) as error:
            print(f"Trial {trial.number} pruned: {error}")
            raise optuna.exceptions.TrialPruned(str(error)) from error
        finally:
            self.n_envs = config_n_envs
