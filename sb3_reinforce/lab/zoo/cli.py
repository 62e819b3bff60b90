"""
The ``sb3-reinforce-zoo`` command: rl_zoo3's commands (same flags and outputs) with REINFORCE registered as
``--algo reinforce``, the shipped agents found for ``-f rl-trained-agents``, and workarounds for rl_zoo3's scripts.
"""

import argparse
import contextlib
import difflib
import importlib
import os
import re
import runpy
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.envpool_vec_env import ENVPOOL
from sb3_reinforce.lab.extras import check_env_id, missing_extra

if TYPE_CHECKING:
    from sb3_reinforce.lab.zoo.storage import FaultTolerance

__all__ = ["COMMANDS", "main", "register"]

PROG = "sb3-reinforce-zoo"


def register() -> None:
    """
    Register REINFORCE in rl_zoo3 as ``reinforce`` (``ALGOS``, Optuna sampler and converter, experiment manager).
    Call it before a zoo command parses its arguments; safe to call more than once.
    """
    import rl_zoo3.train
    from rl_zoo3.hyperparams_opt import HYPERPARAMS_CONVERTER, HYPERPARAMS_SAMPLER
    from rl_zoo3.utils import ALGOS

    from sb3_reinforce.lab.zoo.exp_manager import ALGO_NAME, ReinforceExperimentManager
    from sb3_reinforce.lab.zoo.hyperparams_opt import convert_reinforce_params, sample_reinforce_params

    ALGOS[ALGO_NAME] = REINFORCE
    HYPERPARAMS_SAMPLER[ALGO_NAME] = sample_reinforce_params
    HYPERPARAMS_CONVERTER[ALGO_NAME] = convert_reinforce_params
    rl_zoo3.train.ExperimentManager = ReinforceExperimentManager  # type: ignore[misc]


def _zoo_function(module: str, name: str) -> Callable[[], None]:
    """A command that calls rl_zoo3's ``module.name()`` (imported when the command runs, after :func:`register`)."""
    return lambda: getattr(importlib.import_module(module), name)()


def _zoo_script(module: str, *contexts: Callable[[], contextlib.AbstractContextManager[Any]]) -> Callable[[], None]:
    """A command that runs an rl_zoo3 script as ``__main__`` inside ``contexts`` (a yielded dict: its globals)."""

    def command() -> None:
        with contextlib.ExitStack() as stack:
            init_globals = [stack.enter_context(context()) for context in contexts]
            extra = next((g for g in init_globals if isinstance(g, dict)), None)
            runpy.run_module(module, init_globals=extra, run_name="__main__", alter_sys=True)

    return command


#: rl_zoo3 (2.7 to 2.9.2) subprocess command lines that need a zoo clone and lack REINFORCE -> this package's command.
_SUBPROCESS_COMMANDS = {("python", "enjoy.py"): "enjoy", ("python", "-m", "rl_zoo3.record_video"): "record-video"}


@contextlib.contextmanager
def _subprocesses_through_this_entry_point() -> Iterator[None]:
    """Run the zoo's ``_SUBPROCESS_COMMANDS`` as ``<this python> -m sb3_reinforce.lab.zoo COMMAND ...`` instead."""
    original_call = subprocess.call

    def call(command: Any, *args: Any, **kwargs: Any) -> int:
        if isinstance(command, list):
            for prefix, ours in _SUBPROCESS_COMMANDS.items():
                if tuple(command[: len(prefix)]) == prefix:
                    command = [sys.executable, "-m", "sb3_reinforce.lab.zoo", ours, *command[len(prefix) :]]
                    break
        return original_call(command, *args, **kwargs)

    subprocess.call = call  # type: ignore[assignment]
    try:
        yield
    finally:
        subprocess.call = original_call


@contextlib.contextmanager
def _ffmpeg_on_path() -> Iterator[None]:
    """
    Put imageio-ffmpeg's binary on the PATH as ``ffmpeg`` if missing (rl_zoo3 2.7 to 2.9.2's record_training and
    sb3-team-hf-integration 3.x's replay video call it by name).
    """
    if shutil.which("ffmpeg") is not None:
        yield
        return
    import imageio_ffmpeg

    saved_path = os.environ.get("PATH", "")
    with tempfile.TemporaryDirectory(prefix="sb3-reinforce-ffmpeg-") as folder:
        os.symlink(imageio_ffmpeg.get_ffmpeg_exe(), os.path.join(folder, "ffmpeg"))
        os.environ["PATH"] = os.pathsep.join([folder, saved_path])
        try:
            yield
        finally:
            os.environ["PATH"] = saved_path


def _hub_metadata(model_name: str, env_id: str, mean_reward: float, std_reward: float) -> dict[str, Any]:
    """
    The model card's metadata for push_to_hub, as huggingface_sb3 2.x's ``generate_metadata`` built it.

    :param model_name: The algorithm's class name
    :param env_id: The environment's id
    :param mean_reward: Mean return of the evaluation
    :param std_reward: Its standard deviation
    :return: The metadata, as ``huggingface_hub.repocard.metadata_save`` takes it
    """
    from huggingface_hub.repocard import metadata_eval_result

    evaluation = metadata_eval_result(
        model_pretty_name=model_name,
        task_pretty_name="reinforcement-learning",
        task_id="reinforcement-learning",
        metrics_pretty_name="mean_reward",
        metrics_id="mean_reward",
        metrics_value=f"{mean_reward:.2f} +/- {std_reward:.2f}",
        dataset_pretty_name=env_id,
        dataset_id=env_id,
    )
    tags = [env_id, "deep-reinforcement-learning", "reinforcement-learning", "stable-baselines3", "sb3-reinforce"]
    return {"library_name": "stable-baselines3", "tags": tags, **evaluation}


#: The zoo's commands in the model card push_to_hub writes -> the ones that know ``--algo reinforce``.
_CARD_COMMANDS = (
    (re.compile(r"python -m rl_zoo3\.(\w+)"), rf"{PROG} \1"),
    (re.compile(r"pip install rl_zoo3"), 'pip install "sb3-reinforce[zoo]"'),
)


@contextlib.contextmanager
def _hub_compatibility() -> Iterator[None]:
    """
    Patches for rl_zoo3 2.9.2's Hub scripts while they run:

    - provide ``generate_metadata``, which sb3-team-hf-integration 3.x (huggingface_sb3) dropped, where missing;
    - the model card names this command instead of ``python -m rl_zoo3.enjoy``, which lacks REINFORCE;
    - turn huggingface_hub 1.x's ``EntryNotFoundError`` into the requests ``HTTPError`` load_from_hub expects.
    """
    import huggingface_hub.repocard
    import huggingface_sb3
    import requests
    from huggingface_hub.errors import EntryNotFoundError

    # the module (the package attribute of that name is a function)
    hf_push = importlib.import_module("huggingface_sb3.push_to_hub")

    original_load, original_metadata_save = huggingface_sb3.load_from_hub, huggingface_hub.repocard.metadata_save
    adds_metadata = not hasattr(hf_push, "generate_metadata")

    def load_from_hub(repo_id: str, filename: str) -> str:
        try:
            return original_load(repo_id, filename)
        except EntryNotFoundError as error:
            raise requests.exceptions.HTTPError(str(error)) from error

    def metadata_save(local_path: Any, data: dict[str, Any]) -> None:
        card = Path(local_path)
        text = card.read_text(encoding="utf-8")
        for pattern, replacement in _CARD_COMMANDS:
            text = pattern.sub(replacement, text)
        card.write_text(text, encoding="utf-8")
        original_metadata_save(local_path, data)

    huggingface_sb3.load_from_hub = load_from_hub
    huggingface_hub.repocard.metadata_save = metadata_save
    if adds_metadata:
        hf_push.generate_metadata = _hub_metadata  # type: ignore[attr-defined]
    try:
        yield
    finally:
        huggingface_sb3.load_from_hub = original_load
        huggingface_hub.repocard.metadata_save = original_metadata_save
        if adds_metadata:
            del hf_push.generate_metadata


#: The copy of its table that rl_zoo3's benchmark writes into the current directory.
_ROOT_TABLE = "benchmark.md"


@contextlib.contextmanager
def _table_stays_in_benchmark_dir() -> Iterator[dict[str, Any]]:
    """
    Skip rl_zoo3 2.7 to 2.9.2 benchmark's copy of its table to ``./benchmark.md`` (a stray file outside a zoo clone)
    and its announcement; the table stays in ``--benchmark-dir``.

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


#: Command name -> the rl_zoo3 command it runs, with the workarounds above.
COMMANDS: dict[str, Callable[[], None]] = {
    "train": _zoo_function("rl_zoo3.train", "train"),
    "enjoy": _zoo_function("rl_zoo3.enjoy", "enjoy"),
    "benchmark": _zoo_script("rl_zoo3.benchmark", _subprocesses_through_this_entry_point, _table_stays_in_benchmark_dir),
    "record-video": _zoo_script("rl_zoo3.record_video"),
    "record_training": _zoo_script("rl_zoo3.record_training", _subprocesses_through_this_entry_point, _ffmpeg_on_path),
    "plot_train": _zoo_function("rl_zoo3.plots", "plot_train"),
    "all_plots": _zoo_function("rl_zoo3.plots", "all_plots"),
    "plot_from_file": _zoo_function("rl_zoo3.plots", "plot_from_file"),
    "push_to_hub": _zoo_script("rl_zoo3.push_to_hub", _hub_compatibility, _ffmpeg_on_path),
    "load_from_hub": _zoo_script("rl_zoo3.load_from_hub", _hub_compatibility),
}
# Commands that take one --env (checked first, for a one-line error)
_ENV_COMMANDS = ("train", "enjoy", "record-video", "record_training", "push_to_hub", "load_from_hub")
# Commands that load a trained agent from -f/--folder (default rl-trained-agents)
_AGENT_COMMANDS = ("enjoy", "record-video", "record_training", "push_to_hub")

USAGE = f"""usage: {PROG} {{{",".join(COMMANDS)}}} [zoo arguments ...]

rl-baselines3-zoo (rl_zoo3) with REINFORCE registered as `--algo reinforce`.
Every argument after the command is rl_zoo3's; `{PROG} COMMAND --help` lists them.
With --algo reinforce, `train` reads sb3-reinforce's zoo_configs/reinforce.yml unless -conf/--conf-file is given
(`-conf reinforce_seed`: the seed's agent, shipped too),
and `enjoy`, `record-video`, `record_training` and `push_to_hub` find the shipped agents under -f rl-trained-agents
(the default of the first three).
`train --vec-env envpool` steps the training environments in EnvPool (the envpool extra; the env ids it offers:
sb3_reinforce.lab.envpool_vec_env.ENVPOOL_ENV_IDS); evaluations stay on Gymnasium's environment.
`train` runs torch on one thread unless --num-threads N is given (-1: torch's default, a thread per core): on a
shared 2-core machine torch's default made REINFORCE's learn about 5x slower (benchmarks/results/torch_threads.csv).

`train --optimize` with a database --storage (postgresql://USER:PASSWORD@HOST:5432/DB) also takes:
  --heartbeat-interval S  seconds between the heartbeats of a running trial (default: 60)
  --grace-period S        a trial without a heartbeat for S seconds is failed and retried (default: 180)
  --max-retry N           times a failed trial is retried, with the same hyperparameters (default: 3)
"""


def _check_env_id(args: Sequence[str]) -> None:
    """Raise ZooUsageError if ``--env`` names an environment that is not registered (after ``--gym-packages``)."""
    import rl_zoo3.import_envs  # noqa: F401  (registers the zoo's extra environments)

    from sb3_reinforce.lab.zoo.exp_manager import ZooUsageError

    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--env", type=str, default=None)
    parser.add_argument("--gym-packages", type=str, nargs="+", default=[])
    known, _ = parser.parse_known_args(args)
    for module in known.gym_packages:
        importlib.import_module(module)
    if known.env is not None:
        try:
            check_env_id(known.env)
        except ValueError as error:
            raise ZooUsageError(f"--env: {error}") from None


#: Commands that write videos, by default into the agent's folder (``-o/--output-folder`` to change it).
_VIDEO_COMMANDS = ("record-video", "record_training")


def _shipped_agents_flag(command: str, args: list[str]) -> list[str]:
    """
    Point ``-f rl-trained-agents`` at the folder holding the ``--algo reinforce`` agent (raise ZooUsageError if none).
    Videos of a shipped agent go to ``./videos/reinforce-<env>/`` unless ``-o`` is given.

    :param command: The zoo command
    :param args: Its arguments
    :return: The arguments, with ``-f`` set to that folder (unchanged for another ``--algo`` or ``-f``)
    """
    from sb3_reinforce.lab.zoo.exp_manager import ALGO_NAME, ZooUsageError
    from sb3_reinforce.lab.zoo.shipped import TRAINED_AGENTS, agents_folder, shipped_envs, trained_agents_dirs

    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--algo", type=str, default=None)
    parser.add_argument("--env", type=str, default="CartPole-v1")
    parser.add_argument("-f", "--folder", type=str, default=TRAINED_AGENTS)
    parser.add_argument("-o", "--output-folder", type=str, default=None)
    known, _ = parser.parse_known_args(args)
    if known.algo != ALGO_NAME:
        return args
    folder = agents_folder(known.folder, known.algo, known.env)
    if folder is None:
        raise ZooUsageError(
            f"-f {known.folder}: no trained REINFORCE agent for --env {known.env} here or shipped with sb3-reinforce "
            f"(shipped: {', '.join(shipped_envs()) or 'none'}); train one with `{PROG} train --algo reinforce "
            f"--env {known.env}` and pass -f logs"
        )
    if command in _VIDEO_COMMANDS and known.output_folder is None and Path(folder).resolve() in trained_agents_dirs():
        args = [*args, "-o", os.path.join("videos", f"{ALGO_NAME}-{known.env}")]
    return [*args, "-f", folder] if folder != known.folder else args


def _fault_tolerance_flags(args: Sequence[str]) -> tuple["FaultTolerance", list[str]]:
    """Take this command's own flags (heartbeats and retries of database studies) out of the zoo's arguments."""
    from sb3_reinforce.lab.zoo.storage import FaultTolerance

    defaults = FaultTolerance()
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--heartbeat-interval", type=int, default=defaults.heartbeat_interval)
    parser.add_argument("--grace-period", type=int, default=defaults.grace_period)
    parser.add_argument("--max-retry", type=int, default=defaults.max_retry)
    known, rest = parser.parse_known_args(args)
    return FaultTolerance(known.heartbeat_interval, known.grace_period, known.max_retry), rest


def _one_torch_thread(args: Sequence[str]) -> list[str]:
    """``--num-threads 1`` added to the zoo's arguments unless they set it (rl_zoo3's default, -1, keeps torch's)."""
    if any(arg == "--num-threads" or arg.startswith("--num-threads=") for arg in args):
        return list(args)
    return [*args, "--num-threads", "1"]


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
    import torch as th

    from sb3_reinforce.lab.zoo.exp_manager import ReinforceExperimentManager, ZooUsageError
    from sb3_reinforce.lab.zoo.storage import StorageError

    register()
    fault_tolerance, envpool = ReinforceExperimentManager.fault_tolerance, ReinforceExperimentManager.envpool
    threads = th.get_num_threads()  # train sets its own (--num-threads): the caller's process keeps its count
    saved_argv = sys.argv
    sys.argv = [f"{PROG} {command}", *args]
    try:
        if command in _ENV_COMMANDS:
            _check_env_id(args)
        if command in _AGENT_COMMANDS:
            sys.argv[1:] = _shipped_agents_flag(command, args)
        if command == "train":
            ReinforceExperimentManager.fault_tolerance, rest = _fault_tolerance_flags(args)
            ReinforceExperimentManager.envpool, rest = _vec_env_flag(rest)
            sys.argv[1:] = _one_torch_thread(rest)
        COMMANDS[command]()
    except (ZooUsageError, StorageError) as error:
        print(f"{PROG} {command}: error: {error}", file=sys.stderr)
        return 2
    except SystemExit as exit_:
        # argparse and the zoo's scripts exit this way
        if exit_.code is None or isinstance(exit_.code, int):
            return exit_.code or 0
        print(exit_.code, file=sys.stderr)
        return 1
    finally:
        sys.argv = saved_argv
        ReinforceExperimentManager.fault_tolerance, ReinforceExperimentManager.envpool = fault_tolerance, envpool
        th.set_num_threads(threads)
    return 0
