"""
The ``sb3-reinforce-zoo`` command: rl_zoo3's commands, with REINFORCE registered as ``--algo reinforce``.

Each command is rl_zoo3's own (same flags, same outputs); this module only registers REINFORCE first.
"""

import argparse
import contextlib
import difflib
import importlib
import os
import runpy
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

from sb3_reinforce.cli import missing_extra
from sb3_reinforce.envpool_vec_env import ENVPOOL

if TYPE_CHECKING:
    from sb3_reinforce.zoo.storage import FaultTolerance

__all__ = ["COMMANDS", "main", "register"]

PROG = "sb3-reinforce-zoo"


def register() -> None:
    """
    Register REINFORCE in rl_zoo3 as ``reinforce``: its algorithm table (``ALGOS``, read by train, enjoy,
    record-video, benchmark), its Optuna sampler and converter, and the experiment manager that
    ``rl_zoo3.train`` uses (:class:`~sb3_reinforce.zoo.exp_manager.ReinforceExperimentManager`).
    Safe to call more than once. The zoo builds its ``--algo`` choices when a command parses its
    arguments, so this must run before.
    """
    import rl_zoo3.train
    from rl_zoo3.hyperparams_opt import HYPERPARAMS_CONVERTER, HYPERPARAMS_SAMPLER
    from rl_zoo3.utils import ALGOS

    from sb3_reinforce import REINFORCE
    from sb3_reinforce.zoo.exp_manager import ALGO_NAME, ReinforceExperimentManager
    from sb3_reinforce.zoo.hyperparams_opt import convert_reinforce_params, sample_reinforce_params

    ALGOS[ALGO_NAME] = REINFORCE
    HYPERPARAMS_SAMPLER[ALGO_NAME] = sample_reinforce_params
    HYPERPARAMS_CONVERTER[ALGO_NAME] = convert_reinforce_params
    rl_zoo3.train.ExperimentManager = ReinforceExperimentManager  # type: ignore[misc]


def _train() -> None:
    from rl_zoo3.train import train

    train()


def _enjoy() -> None:
    from rl_zoo3.enjoy import enjoy

    enjoy()


def _record_video() -> None:
    runpy.run_module("rl_zoo3.record_video", run_name="__main__", alter_sys=True)


@contextlib.contextmanager
def _enjoy_through_this_entry_point() -> Iterator[None]:
    """
    rl_zoo3's benchmark evaluates each agent with ``subprocess.call(["python", "enjoy.py", ...])``, which only
    works from a clone of the zoo and does not know REINFORCE: run those evaluations as
    ``<this python> -m sb3_reinforce.zoo enjoy ...`` instead. Any other call is left alone.
    """
    original_call = subprocess.call

    def call(command: Any, *args: Any, **kwargs: Any) -> int:
        if isinstance(command, list) and command[:2] == ["python", "enjoy.py"]:
            command = [sys.executable, "-m", "sb3_reinforce.zoo", "enjoy", *command[2:]]
        return original_call(command, *args, **kwargs)

    subprocess.call = call  # type: ignore[assignment]
    try:
        yield
    finally:
        subprocess.call = original_call


#: The copy of its table that rl_zoo3's benchmark writes into the current directory (its own repository's root).
_ROOT_TABLE = "benchmark.md"


@contextlib.contextmanager
def _table_stays_in_benchmark_dir() -> Iterator[dict[str, Any]]:
    """
    rl_zoo3's benchmark writes its table to ``--benchmark-dir``/benchmark.md and then, without ``--test-mode``,
    copies it to ``./benchmark.md`` (``shutil.copy(tmp_path, "benchmark.md")``): in the zoo's own clone that is its
    README's table, anywhere else a stray file in the current directory. Leave that copy out (the table is already
    in the benchmark folder) and drop the line that announces it.

    :return: Globals for ``runpy.run_module`` (a ``print`` that drops the announcement of the copy)
    """
    original_copy = shutil.copy

    def copy(src: Any, dst: Any, *args: Any, **kwargs: Any) -> Any:
        if os.fspath(dst) == _ROOT_TABLE:
            return os.fspath(src)
        return original_copy(src, dst, *args, **kwargs)

    def print_(*args: Any, **kwargs: Any) -> None:
        if args != (f"Results copied to: {_ROOT_TABLE}",):
            print(*args, **kwargs)

    shutil.copy = copy
    try:
        yield {"print": print_}
    finally:
        shutil.copy = original_copy


def _benchmark() -> None:
    with _enjoy_through_this_entry_point(), _table_stays_in_benchmark_dir() as init_globals:
        runpy.run_module("rl_zoo3.benchmark", init_globals=init_globals, run_name="__main__", alter_sys=True)


#: Command name -> the rl_zoo3 command it runs.
COMMANDS: dict[str, Callable[[], None]] = {
    "train": _train,
    "enjoy": _enjoy,
    "benchmark": _benchmark,
    "record-video": _record_video,
}
# Commands that take --env (checked here first, for a short error instead of a traceback).
_ENV_COMMANDS = ("train", "enjoy", "record-video")

USAGE = f"""usage: {PROG} {{{",".join(COMMANDS)}}} [zoo arguments ...]

rl-baselines3-zoo (rl_zoo3) with REINFORCE registered as `--algo reinforce`.
Every argument after the command is rl_zoo3's; `{PROG} COMMAND --help` lists them.
With --algo reinforce, `train` reads sb3-reinforce's zoo_configs/reinforce.yml unless -conf/--conf-file is given.
`train --vec-env envpool` steps the training environments in EnvPool (the envpool extra; the env ids it offers:
sb3_reinforce.envpool_vec_env.ENVPOOL_ENV_IDS); evaluations stay on Gymnasium's environment.

`train --optimize` with a database --storage (postgresql://USER:PASSWORD@HOST:5432/DB) also takes:
  --heartbeat-interval S  seconds between the heartbeats of a running trial (default: 60)
  --grace-period S        a trial without a heartbeat for S seconds is failed and retried (default: 180)
  --max-retry N           times a failed trial is retried, with the same hyperparameters (default: 3)
"""


def _check_env_id(args: Sequence[str]) -> None:
    """Raise ZooUsageError if ``--env`` names an environment that is not registered (after ``--gym-packages``)."""
    import gymnasium as gym
    import rl_zoo3.import_envs  # noqa: F401  (registers the zoo's extra environments)

    from sb3_reinforce.zoo.exp_manager import ZooUsageError

    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--env", type=str, default=None)
    parser.add_argument("--gym-packages", type=str, nargs="+", default=[])
    known, _ = parser.parse_known_args(args)
    for module in known.gym_packages:
        importlib.import_module(module)
    if known.env is None or known.env in gym.envs.registry:
        return
    close = difflib.get_close_matches(known.env, list(gym.envs.registry), n=3)
    hint = f" Did you mean {' or '.join(close)}?" if close else ""
    raise ZooUsageError(f"--env {known.env}: no such environment in the Gymnasium registry.{hint}")


def _fault_tolerance_flags(args: Sequence[str]) -> tuple["FaultTolerance", list[str]]:
    """Take this command's own flags (heartbeats and retries of database studies) out of the zoo's arguments."""
    from sb3_reinforce.zoo.storage import FaultTolerance

    defaults = FaultTolerance()
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--heartbeat-interval", type=int, default=defaults.heartbeat_interval)
    parser.add_argument("--grace-period", type=int, default=defaults.grace_period)
    parser.add_argument("--max-retry", type=int, default=defaults.max_retry)
    known, rest = parser.parse_known_args(args)
    return FaultTolerance(known.heartbeat_interval, known.grace_period, known.max_retry), rest


def _vec_env_flag(args: Sequence[str]) -> tuple[bool, list[str]]:
    """Take ``--vec-env envpool`` (this command's own choice) out of the zoo's arguments: whether it was given."""
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--vec-env", type=str, default=None)
    known, rest = parser.parse_known_args(args)
    if known.vec_env == ENVPOOL:
        return True, rest
    return False, list(args)


def main(argv: Sequence[str] | None = None) -> int:
    """
    Run an rl_zoo3 command with REINFORCE registered.

    :param argv: ``[command, *zoo_arguments]``; default: ``sys.argv[1:]``
    :return: The exit status (0: success, 2: a usage or config error, reported in one line on stderr)
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE, file=sys.stdout if argv else sys.stderr)
        return 0 if argv else 2
    command, args = argv[0], argv[1:]
    if command not in COMMANDS:
        close = difflib.get_close_matches(command, list(COMMANDS), n=1)
        hint = f" Did you mean {close[0]}?" if close else ""
        print(f"{PROG}: error: unknown command {command!r}, choose from {', '.join(COMMANDS)}.{hint}", file=sys.stderr)
        return 2
    try:
        import rl_zoo3  # noqa: F401
    except ImportError as error:
        print(f"{PROG}: error: rl_zoo3 is not installed ({error}): pip install 'sb3-reinforce[zoo]'", file=sys.stderr)
        return 2
    try:
        with missing_extra(f"{PROG} {command}", "zoo"), missing_extra(f"{PROG} {command}", "envpool"):
            return _run(command, args)
    except SystemExit as exit_:  # missing_extra's exit
        return int(exit_.code or 0)


def _run(command: str, args: list[str]) -> int:
    """Run one zoo command with REINFORCE registered; usage and config errors become one line and status 2."""
    from sb3_reinforce.zoo.exp_manager import ReinforceExperimentManager, ZooUsageError
    from sb3_reinforce.zoo.storage import StorageError

    register()
    fault_tolerance, envpool = ReinforceExperimentManager.fault_tolerance, ReinforceExperimentManager.envpool
    saved_argv = sys.argv
    sys.argv = [f"{PROG} {command}", *args]
    try:
        if command in _ENV_COMMANDS:
            _check_env_id(args)
        if command == "train":
            ReinforceExperimentManager.fault_tolerance, rest = _fault_tolerance_flags(args)
            ReinforceExperimentManager.envpool, sys.argv[1:] = _vec_env_flag(rest)
        COMMANDS[command]()
    except (ZooUsageError, StorageError) as error:
        print(f"{PROG} {command}: error: {error}", file=sys.stderr)
        return 2
    except SystemExit as exit_:
        # argparse (--help, an invalid --algo choice, ...) and the zoo's scripts exit this way
        if exit_.code is None or isinstance(exit_.code, int):
            return exit_.code or 0
        print(exit_.code, file=sys.stderr)
        return 1
    finally:
        sys.argv = saved_argv
        ReinforceExperimentManager.fault_tolerance, ReinforceExperimentManager.envpool = fault_tolerance, envpool
    return 0
