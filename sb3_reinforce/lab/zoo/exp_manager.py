"""
rl_zoo3's ``ExperimentManager`` with what REINFORCE needs on top:

- ``--algo reinforce`` reads ``zoo_configs/reinforce.yml`` unless ``-conf/--conf-file`` is given; config errors raise
  :class:`ZooUsageError` before anything is built.
- ``--optimize`` also samples ``n_envs`` and observation normalization, and prunes trials that make REINFORCE fail;
  a database ``--storage`` is fault-tolerant (:mod:`sb3_reinforce.lab.zoo.storage`).
- ``--vec-env envpool`` trains on EnvPool (:mod:`sb3_reinforce.lab.envpool_vec_env`); evaluation stays on Gymnasium.
"""

import contextlib
import inspect
import math
import os
import socket
import sys
import time
import uuid
from pathlib import Path
from typing import Any

import optuna
import yaml
from rl_zoo3.exp_manager import ExperimentManager
from rl_zoo3.utils import ALGOS
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv

from sb3_reinforce.lab.envpool_vec_env import ENVPOOL, WrapperSpec, check_envpool_env, envpool_vec_env_class, split_wrappers
from sb3_reinforce.lab.zoo.hyperparams_opt import NORMALIZE_OBSERVATIONS_KWARGS, suggest_n_envs, suggest_normalize_observations
from sb3_reinforce.lab.zoo.shipped import CONFIG_NAMES, config_path
from sb3_reinforce.lab.zoo.storage import (
    DATABASE_ERRORS,
    FaultTolerance,
    FaultTolerantStorage,
    caused_by_database,
    check_direction,
    held_slots,
    is_database_url,
    open_database_storage,
    surplus_reason,
)
from sb3_reinforce.reinforce.buffers import RolloutLimitError
from sb3_reinforce.reinforce.reinforce import check_hyperparameters, hyperparameter_defaults
from sb3_reinforce.safeguards import TrimHeap

__all__ = ["ALGO_NAME", "ReinforceExperimentManager", "ZooUsageError"]

#: The name of REINFORCE in the zoo's ``--algo``.
ALGO_NAME = "reinforce"

# Keys of a zoo config that the zoo itself consumes (never passed to the algorithm).
_ZOO_KEYS = {"env", "tensorboard_log", "seed", "verbose", "device"}

# Part of this process's worker name in a distributed study
_PROCESS_TOKEN = uuid.uuid4().hex[:8]


class SurplusTrial(RuntimeError):
    """A trial started when the study already had its ``--max-total-trials`` (two workers started at once)."""


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


def wrapper_specs(entry: Any) -> list[WrapperSpec]:
    """
    The classes and arguments of a zoo entry's ``env_wrapper`` (a name, or a list of names and ``{name: kwargs}``).

    :param entry: The entry's ``env_wrapper`` value (None: no wrapper)
    :return: (class, keyword arguments) pairs, innermost first
    """
    from rl_zoo3.utils import get_class_by_name

    items = [] if entry is None else entry if isinstance(entry, list) else [entry]
    specs = []
    for item in items:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        specs.append((get_class_by_name(name), dict(kwargs or {})))
    return specs


def check_reinforce_values(hyperparams: dict[str, Any]) -> None:
    """
    Run REINFORCE's argument checks on a config's values, constructor defaults filling the gaps.

    :param hyperparams: Constructor keyword arguments (as the zoo passes them)
    """
    check_hyperparameters({name: hyperparams.get(name, default) for name, default in hyperparameter_defaults().items()})


class ReinforceExperimentManager(ExperimentManager):
    """rl_zoo3's ``ExperimentManager`` (same arguments) with REINFORCE's defaults and checks (see the module docstring)."""

    #: Heartbeats and retries of studies in a database (``sb3-reinforce-zoo train`` sets it from its flags).
    fault_tolerance: FaultTolerance = FaultTolerance()
    #: The flag that names another hyperparameter file, in the errors (``sb3-reinforce compare`` has its own).
    config_flag: str = "-conf/--conf-file"
    #: How long a worker keeps trying to reach a database that went away before it gives up (seconds).
    reconnect_timeout: float = 300.0
    #: Train on EnvPool whatever ``vec_env_type`` says (rl_zoo3's own flag offers dummy and subproc only).
    envpool: bool = False
    #: EnvPool's worker threads (0: EnvPool's default, one per core; ``sb3-reinforce compare`` sets 1).
    envpool_threads: int = 0
    #: ``None`` if the env has its own entry, else rl_zoo3's fallback (``"atari"`` or ``"default"``).
    fallback_entry: str | None = None

    def __init__(self, args: Any, algo: str, *positional: Any, config: str | None = None, **kwargs: Any) -> None:
        if config is None and algo == ALGO_NAME:
            config = str(config_path("reinforce"))
        elif config in CONFIG_NAMES:  # a shipped file by its name (`-conf reinforce_seed`), from anywhere
            config = str(config_path(config))
        if config is not None and config.endswith((".yml", ".yaml")) and not os.path.isfile(config):
            raise ZooUsageError(f"Hyperparameter file {config} (-conf/--conf-file) does not exist")
        kwargs["config"] = config
        #: Whether the training environments step in EnvPool
        self.on_envpool = self.envpool or kwargs.get("vec_env_type") == ENVPOOL
        if self.on_envpool:
            kwargs["vec_env_type"] = "dummy"  # rl_zoo3's own choice until create_envs
            if hasattr(args, "vec_env"):
                args.vec_env = ENVPOOL  # the run's args.yml says which backend trained it
        self._env_wrappers: list[WrapperSpec] = []
        super().__init__(args, algo, *positional, **kwargs)
        if self.on_envpool:
            try:
                check_envpool_env(self.env_name.gym_id)
            except ValueError as error:
                raise ZooUsageError(f"--vec-env envpool: {error}") from error

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
            # rl_zoo3's order: the env's own entry, else "atari" for an Atari env (never "default"), else "default"
            fallback = "atari" if self._is_atari else "default"
            if env_id not in entries and fallback not in entries:
                raise ZooUsageError(
                    f"{self.config} has no entry for {env_id} (it has: {', '.join(sorted(entries))})"
                    + (", nor the 'atari' entry rl_zoo3 uses for Atari envs" if self._is_atari else "")
                    + f". Add one, or pass another file with {self.config_flag}."
                )
            if env_id not in entries:
                self.fallback_entry = fallback
        hyperparams, saved_hyperparams = super().read_hyperparameters()
        if self.trial_id == 0 and self.storage and self.study_name:
            # rl_zoo3 tests `if self.trial_id:`, which skips trial 0: load it here, -params still on top
            from_study = {**self.load_trial(self.storage, self.study_name, 0), **(self.custom_hyperparams or {})}
            hyperparams.update(from_study)
            saved_hyperparams.update(from_study)
        return hyperparams, saved_hyperparams

    def _preprocess_hyperparams(self, hyperparams: dict[str, Any]) -> tuple[dict[str, Any], Any, list[BaseCallback], Any]:
        where = f"{self.config} [{self.env_name.gym_id}]"
        if self.custom_hyperparams:
            where += f" with -params {' '.join(sorted(self.custom_hyperparams))}"
        if self.on_envpool:
            self._env_wrappers = wrapper_specs(hyperparams.get("env_wrapper"))
            try:
                split_wrappers(self._env_wrappers)
            except ValueError as error:
                raise ZooUsageError(f"{where}: {error}") from error
        processed, env_wrapper, callbacks, vec_env_wrapper = super()._preprocess_hyperparams(hyperparams)
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
            # Whole-episode batches change size at every update: give the freed heap back (see TrimHeap)
            callbacks = [*callbacks, TrimHeap()]
        return processed, env_wrapper, callbacks, vec_env_wrapper

    def create_envs(self, n_envs: int, eval_env: bool = False, no_log: bool = False) -> VecEnv:
        """
        rl_zoo3's environments; on EnvPool the training ones are EnvPool's, the evaluation ones stay Gymnasium's.

        :param n_envs: Number of environments
        :param eval_env: Whether they evaluate
        :param no_log: No monitor file
        :return: The environments, wrapped as the entry says (``VecNormalize``, frame stack, image transpose)
        """
        if not self.on_envpool:
            return super().create_envs(n_envs, eval_env, no_log)
        vec_env_class = self.vec_env_class
        if eval_env:
            self.vec_env_class = DummyVecEnv
        else:
            monitor_dir = None if no_log else self.save_path
            self.vec_env_class = envpool_vec_env_class(  # type: ignore[assignment]
                self.env_name.gym_id,
                self._env_wrappers,
                self.env_kwargs,
                monitor_dir,
                self.monitor_kwargs,
                num_threads=self.envpool_threads,
            )
        try:
            return super().create_envs(n_envs, eval_env, no_log)
        finally:
            self.vec_env_class = vec_env_class

    def objective(self, trial: optuna.Trial) -> float:
        """
        Train and evaluate one trial (for REINFORCE, sampling ``n_envs`` and normalization too). Its own error (not the
        database's) or a non-finite value is recorded in its ``error`` user attribute: it is not retried.

        :param trial: The Optuna trial
        :return: The last mean evaluation reward
        """
        trial.set_user_attr("worker", self._worker_name())
        if self.max_total_trials is not None and is_database_url(self.storage):
            self._check_slot(trial, self.max_total_trials)
        try:
            value = self._train_trial(trial)
        except (optuna.exceptions.TrialPruned, SurplusTrial):
            raise
        except Exception as error:
            if not caused_by_database(error):
                self._record_error(trial, f"{type(error).__name__}: {error}")
            raise
        if not math.isfinite(value):  # Optuna records the trial FAIL: a failure of its own, not to be retried
            self._record_error(trial, f"the objective value is {value}")
        return value

    @staticmethod
    def _record_error(trial: optuna.Trial, message: str) -> None:
        """Record the trial's own error in its ``error`` user attribute, where the database can still be reached."""
        with contextlib.suppress(*DATABASE_ERRORS):
            trial.set_user_attr("error", message[:1000])

    def _train_trial(self, trial: optuna.Trial) -> float:
        if self.algo != ALGO_NAME:
            return super().objective(trial)
        config_n_envs, config_normalize, config_normalize_kwargs = self.n_envs, self.normalize, self.normalize_kwargs
        self.n_envs = suggest_n_envs(trial)
        if not config_normalize and suggest_normalize_observations(trial):
            self.normalize, self.normalize_kwargs = True, dict(NORMALIZE_OBSERVATIONS_KWARGS)
        try:
            return super().objective(trial)
        except (FloatingPointError, RolloutLimitError) as error:  # a non-finite update, an episode that never ends
            print(f"Trial {trial.number} pruned: {error}")
            raise optuna.exceptions.TrialPruned(str(error)) from error
        finally:
            self.n_envs, self.normalize, self.normalize_kwargs = config_n_envs, config_normalize, config_normalize_kwargs

    def _check_slot(self, trial: optuna.Trial, total: int) -> None:
        """Record a trial started beyond the total, or a second retry of one trial, FAIL as "surplus", unrun."""
        trials = trial.study.get_trials(deepcopy=False)
        reason = surplus_reason(trial.number, trials, total, self.fault_tolerance.max_retry)
        if reason is not None:
            trial.set_user_attr("surplus", True)
            raise SurplusTrial(f"Trial {trial.number}: {reason}")

    def hyperparameters_optimization(self) -> None:
        """rl_zoo3's optimization; with a database storage, fault-tolerant (:mod:`sb3_reinforce.lab.zoo.storage`)."""
        if not self.optimize_hyperparameters or not is_database_url(self.storage):
            return super().hyperparameters_optimization()
        assert self.storage is not None
        storage = open_database_storage(self.storage, self.fault_tolerance)
        study = optuna.create_study(
            sampler=self._create_sampler(self.sampler),
            pruner=self._create_pruner(self.pruner),
            storage=storage,
            study_name=self.study_name,
            load_if_exists=True,
            direction="maximize",
        )
        check_direction(study, optuna.study.StudyDirection.MAXIMIZE)
        self.study_name = study.study_name
        try:
            self._run_trials(study, storage)
        except KeyboardInterrupt:
            pass
        # rl_zoo3 reports on the study (best trial, CSV, plots), told to run no trial
        limits = self.n_trials, self.max_total_trials
        self.n_trials, self.max_total_trials = 0, None
        try:
            super().hyperparameters_optimization()
        finally:
            self.n_trials, self.max_total_trials = limits

    def _run_trials(self, study: optuna.Study, storage: FaultTolerantStorage) -> None:
        """
        Run trials (dead workers' retries included) until ``n_trials`` here, or ``max_total_trials`` in the study, are
        done.

        :param study: The study
        :param storage: Its storage (the one the study was created with)
        """
        if "command" not in study.user_attrs:  # rl_zoo3's record of the study's command and default hyperparameters
            study.set_user_attr("command", " ".join(sys.orig_argv))
            for key in sorted(self._hyperparams):
                study.set_user_attr(key, str(self._hyperparams[key]))
        finished_states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
        tolerance = self.fault_tolerance
        done_here = 0
        lost_since: float | None = None
        while True:
            try:
                optuna.storages.fail_stale_trials(study)  # dead workers' trials: FAIL, and a retry is enqueued
                # Queue retries of this worker's trials failed by a lost database, and of dead workers' orphans
                storage.retry_failed_trials(study, self._worker_name(), orphaned_after=tolerance.grace_period)
                trials = study.get_trials(deepcopy=False)
                lost_since = None
            except DATABASE_ERRORS as error:
                lost_since = self._wait_for_database(error, lost_since)
                continue
            if self.max_total_trials is None:
                if done_here >= self.n_trials:
                    return
            else:
                finished = sum(t.state in finished_states for t in trials)
                waiting = sum(t.state == optuna.trial.TrialState.WAITING for t in trials)
                if finished >= self.max_total_trials and waiting == 0:
                    return
                if held_slots(trials, tolerance.max_retry) >= self.max_total_trials and waiting == 0:
                    time.sleep(min(tolerance.heartbeat_interval, 5))  # the last trials run (or are retried) elsewhere
                    continue
            try:
                # A trial beyond the total (a race) or a retry queued twice is recorded FAIL as "surplus", unrun
                study.optimize(self.objective, n_trials=1, gc_after_trial=True, catch=(SurplusTrial,))
                done_here += 1
            except Exception as error:
                if not caused_by_database(error):
                    raise
                # The trial stays RUNNING (retried after the grace period) or Optuna failed it (retried here later)
                lost_since = self._wait_for_database(error, lost_since)

    @staticmethod
    def _worker_name() -> str:
        """This worker as ``host:token:pid``; the per-process random token separates workers sharing host name and PID."""
        return f"{socket.gethostname()}:{_PROCESS_TOKEN}:{os.getpid()}"

    def _wait_for_database(self, error: BaseException, lost_since: float | None) -> float:
        now = time.monotonic()
        lost_since = now if lost_since is None else lost_since
        if now - lost_since > self.reconnect_timeout:
            raise RuntimeError(f"The study's database has been unreachable for {self.reconnect_timeout:.0f} s: {error}")
        print(f"The study's database is unreachable ({str(error).strip().splitlines()[0]}); retrying")
        time.sleep(min(self.fault_tolerance.heartbeat_interval, 5))
        return lost_since
