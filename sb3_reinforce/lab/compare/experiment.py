"""
Build each comparison run with rl_zoo3's ``ExperimentManager`` exactly as ``sb3-reinforce-zoo train`` does (only the
evaluation environment is the comparison's own). REINFORCE's hyperparameters come from ``zoo_configs/reinforce.yml``,
every other algorithm's from the *installed* rl_zoo3 (``rl_zoo3/hyperparams/<algo>.yml``), unless ``--config ALGO=FILE``
names another file.
"""

import argparse
import contextlib
import io
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv

from sb3_reinforce.lab.compare.evaluation import Evaluator, episode_batch
from sb3_reinforce.lab.envpool_vec_env import ENVPOOL, check_envpool_env
from sb3_reinforce.lab.extras import check_env_id

__all__ = [
    "DEFAULT_ALGOS",
    "EVAL_SEED_OFFSET",
    "VEC_ENV_TYPES",
    "BuiltRun",
    "ZooEntry",
    "build_run",
    "check_device",
    "check_vec_env",
    "check_where",
    "known_algos",
    "read_entry",
    "run_cpus",
]

#: The algorithms compared when ``--algos`` is not given.
DEFAULT_ALGOS = ("reinforce", "ppo", "a2c")
#: The evaluation environment's seed is the run's seed plus this (the training envs use seed .. seed + n_envs - 1).
EVAL_SEED_OFFSET = 10_000
#: How a run steps its training environments (rl_zoo3's ``--vec-env``): in its process (``DummyVecEnv``), one process
#: per environment (``SubprocVecEnv``), or EnvPool's C++ threads (:mod:`sb3_reinforce.lab.envpool_vec_env`). The
#: evaluation environment is Gymnasium's with all three.
VEC_ENV_TYPES = ("dummy", "subproc", ENVPOOL)


def check_vec_env(vec_env: str, env_id: str) -> None:
    """
    Check, before anything is built, that ``env_id``'s training environments can be stepped as ``vec_env``.

    :param vec_env: One of :data:`VEC_ENV_TYPES`
    :param env_id: The environment id
    :raises ValueError: an unknown ``vec_env``, or an environment that EnvPool does not offer
    :raises ModuleNotFoundError: ``envpool`` without EnvPool installed
    """
    if vec_env not in VEC_ENV_TYPES:
        raise ValueError(f"vec_env must be one of {', '.join(VEC_ENV_TYPES)}, got {vec_env!r}")
    if vec_env == ENVPOOL:
        check_envpool_env(env_id)


def check_device(device: str, here: bool = True) -> None:
    """
    Check, before anything is built, that ``device`` is cpu, cuda, cuda:N, mps or auto (and, with ``here``, present).

    :param device: Where the runs' networks compute
    :param here: Whether the runs train on this machine (a local cluster); with a remote scheduler the workers decide
    :raises ValueError: another name (wherever the runs train), or a GPU this machine lacks
    """
    if device == "auto":
        return
    try:
        parsed: th.device | None = th.device(device)
    except RuntimeError:
        parsed = None
    if parsed is None or parsed.type not in ("cpu", "cuda", "mps"):
        raise ValueError(f"device must be cpu, cuda, cuda:N, mps or auto (a PyTorch device), got {device!r}")
    if not here:
        return
    if parsed.type == "cuda":
        count = th.cuda.device_count()
        if (parsed.index or 0) >= count:
            raise ValueError(f"device {device!r}: PyTorch {th.__version__} sees {count} CUDA device(s) here")
    elif parsed.type == "mps" and not th.backends.mps.is_available():
        raise ValueError(f"device {device!r}: PyTorch {th.__version__} has no MPS device here")


def run_cpus(n_envs: int, vec_env: str) -> int:
    """
    The CPUs a run keeps busy: ``n_envs`` with ``subproc``, else one (``envpool`` steps while the run waits).

    :param n_envs: The run's training environments
    :param vec_env: How they are stepped, one of :data:`VEC_ENV_TYPES`
    :return: The CPUs (the worker resource the run asks for)
    """
    return n_envs if vec_env == "subproc" else 1


def known_algos() -> list[str]:
    """Every algorithm the installed rl_zoo3 knows, REINFORCE included (registered first)."""
    from rl_zoo3.utils import ALGOS

    from sb3_reinforce.lab.zoo import register

    register()
    return sorted(ALGOS)


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    # The zoo prints every hyperparameter it reads: keep a many-run comparison's output short.
    with contextlib.redirect_stdout(io.StringIO()):
        yield


def _manager(
    algo: str,
    env_id: str,
    seed: int,
    budget: int,
    log_folder: str,
    config: Path | None,
    vec_env: str = "dummy",
    device: str = "cpu",
) -> Any:
    from sb3_reinforce.lab.zoo.exp_manager import ReinforceExperimentManager

    known_algos()  # registers REINFORCE
    args = argparse.Namespace(algo=algo, env=env_id, seed=seed, n_timesteps=budget, conf_file=config, source="compare")
    return ReinforceExperimentManager(
        args,
        algo,
        env_id,
        log_folder,
        n_timesteps=budget,
        eval_freq=-1,  # the comparison evaluates with its own callback
        seed=seed,
        verbose=0,
        device=device,
        config=None if config is None else str(config),
        vec_env_type=vec_env,
    )


@dataclass
class ZooEntry:
    """
    One algorithm's zoo entry for one environment, read and checked as ``sb3-reinforce-zoo train`` reads it.

    :param algo: Lower-case algorithm name (rl_zoo3's ``--algo``)
    :param env_id: The environment id
    :param source: The yml file it was read from
    :param n_envs: Number of training environments
    :param n_timesteps: The entry's training budget
    :param hyperparams: The entry as written in the file (for the record)
    :param fallback: None if the file has an entry for ``env_id``, else rl_zoo3's untuned ``"default"`` or ``"atari"``
    """

    algo: str
    env_id: str
    source: Path
    n_envs: int
    n_timesteps: int
    hyperparams: dict[str, Any] = field(default_factory=dict)
    fallback: str | None = None


def read_entry(algo: str, env_id: str, config: Path | None = None, vec_env: str = "dummy") -> ZooEntry:
    """
    Read and check ``algo``'s entry for ``env_id`` without building anything.

    :param algo: An algorithm of :func:`known_algos`
    :param env_id: The environment id
    :param config: The yml file (default: REINFORCE's zoo config, or the installed rl_zoo3's file for the algorithm)
    :param vec_env: How the training environments will be stepped, one of :data:`VEC_ENV_TYPES`
    :return: The entry
    :raises ValueError: a missing file or entry, an unknown key, a bad REINFORCE value, or a wrapper EnvPool lacks
    """
    known = known_algos()
    if algo not in known:
        raise ValueError(f"Unknown algorithm {algo!r}: choose among {', '.join(known)}")
    manager = _manager(algo, env_id, 0, 0, os.devnull, config, vec_env)
    manager.config_flag = f"--config {algo}=FILE"  # compare's flag for an algorithm's file
    with _quiet():
        try:
            hyperparams, saved = manager.read_hyperparameters()
        except FileNotFoundError as error:
            raise ValueError(f"{algo}: no hyperparameter file ({error})") from None
        except ValueError as error:  # rl_zoo3's own "Hyperparameters not found for ..."
            raise ValueError(str(error).splitlines()[0]) from None
        manager._preprocess_hyperparams(hyperparams)
    return _entry(manager, algo, env_id, saved)


def check_where(env_id: str, vec_env: str = "dummy", device: str = "cpu", here: bool = True) -> None:
    """
    Check, before anything is built, that runs of ``env_id`` can train as asked: a registered env, a ``vec_env`` that
    can step it, a ``device`` there is.

    :param env_id: The environment id (its packages imported first)
    :param vec_env: How the training environments will be stepped, one of :data:`VEC_ENV_TYPES`
    :param device: Where the networks will compute, see :func:`check_device`
    :param here: Whether the runs train on this machine (see :func:`check_device`)
    :raises ValueError: naming what to change
    """
    check_env_id(env_id)
    check_vec_env(vec_env, env_id)
    check_device(device, here)


def _entry(manager: Any, algo: str, env_id: str, saved: dict[str, Any]) -> ZooEntry:
    """The :class:`ZooEntry` a manager has read (``saved``: the entry as the zoo saves it)."""
    source = Path(manager.config)
    return ZooEntry(algo, env_id, source, int(manager.n_envs), int(manager.n_timesteps), dict(saved), manager.fallback_entry)


@dataclass
class BuiltRun:
    """
    What one run trains and evaluates: the model, its training env, the evaluation env, the zoo's callbacks, and the
    evaluator of ``n_eval_episodes`` episodes on the evaluation env.
    """

    model: BaseAlgorithm
    train_env: VecEnv
    eval_env: VecEnv
    callbacks: list[BaseCallback]
    entry: ZooEntry
    evaluator: Evaluator

    def close(self) -> None:
        """Close the training and evaluation environments."""
        self.train_env.close()
        self.evaluator.close()


def build_run(
    algo: str,
    env_id: str,
    seed: int,
    budget: int,
    log_folder: Path,
    config: Path | None = None,
    vec_env: str = "dummy",
    envpool_threads: int = 1,
    device: str = "cpu",
    n_eval_episodes: int = 1,
) -> BuiltRun:
    """
    Build one run as ``sb3-reinforce-zoo train`` would, plus an evaluation ``DummyVecEnv`` from the same manager
    (``VecNormalize`` in evaluation mode) seeded ``seed + EVAL_SEED_OFFSET``, and its evaluator: with
    ``n_eval_episodes > 1``, as many copies of the evaluation env play the deterministic episodes side by side where
    :func:`~sb3_reinforce.lab.compare.evaluation.episode_batch` allows it.

    :param algo: An algorithm of :func:`known_algos`
    :param env_id: The environment id
    :param seed: The run's seed
    :param budget: Training steps
    :param log_folder: Where the zoo writes the run's own files (monitor logs, the config it used)
    :param config: The algorithm's yml file (default: as :func:`read_entry`)
    :param vec_env: How the training environments are stepped, one of :data:`VEC_ENV_TYPES`
    :param envpool_threads: EnvPool's threads with ``vec_env="envpool"`` (1: a run's one core; 0: one per core)
    :param device: Where the model's networks compute (PyTorch's device), see :func:`check_device`
    :param n_eval_episodes: Episodes of each kind (deterministic, sampled actions) per evaluation
    :return: The run, ready to ``model.learn``
    """
    check_vec_env(vec_env, env_id)
    manager = _manager(algo, env_id, seed, budget, str(log_folder), config, vec_env, device)
    manager.envpool_threads = envpool_threads
    with _quiet():
        built = manager.setup_experiment()
        assert built is not None, "setup_experiment() builds a model unless optimizing"
        model, saved = built
        manager.seed = seed + EVAL_SEED_OFFSET
        manager.vec_env_class = DummyVecEnv
        try:
            eval_env = manager.create_envs(1, eval_env=True)
            copies = manager.create_envs(n_eval_episodes, eval_env=True) if n_eval_episodes > 1 else None
        finally:
            manager.seed = seed
    entry = _entry(manager, algo, env_id, saved)
    train_env = model.get_env()
    assert train_env is not None
    batch = None if copies is None else episode_batch(eval_env, copies)
    evaluator = Evaluator(eval_env, n_eval_episodes, batch)
    return BuiltRun(model, train_env, eval_env, list(manager.callbacks), entry, evaluator)
