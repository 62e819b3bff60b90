"""
One run of the comparison (one algorithm, one seed): train, and every ``eval_freq`` steps evaluate ``n_eval_episodes``
deterministic then as many stochastic episodes on a separate environment, appending each evaluation to the run's CSV.
After each evaluation a :class:`Checkpoint` is saved; a run interrupted after its first evaluation resumes from it when
run again with the same settings (weights, optimizer, steps and schedules kept; running episodes lost, so its curve
differs, see ``resumed_at_steps``). Off-policy runs are not checkpointed: ``model.save`` omits the replay buffer.
"""

import contextlib
import csv
import io
import json
import os
import pickle
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import psutil
import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.distributions import StateDependentNoiseDistribution
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv, sync_envs_normalization

from sb3_reinforce.lab.compare.evaluation import EpisodeBatch, episode_batch
from sb3_reinforce.lab.compare.experiment import build_run
from sb3_reinforce.lab.compare.figures import PER_RUN_DIR
from sb3_reinforce.safeguards import load_with_random_state, save_with_random_state
from sb3_reinforce.version import __version__

__all__ = [
    "RESULT_COLUMNS",
    "Checkpoint",
    "ComparisonEvalCallback",
    "RunSpec",
    "code_version",
    "process_tree_cpu_s",
    "process_tree_rss_mb",
    "run",
    "write_replacing",
]

#: Columns of ``results.csv``: one row per algorithm, seed and evaluation point.
RESULT_COLUMNS = [
    "env",
    "algo",
    "seed",
    "eval_index",
    "steps",
    "episodes",
    "wall_time_s",
    "mean_return",
    "std_return",
    "mean_return_stochastic",
    "std_return_stochastic",
    "peak_rss_mb",
]


@dataclass(frozen=True)
class RunSpec:
    """
    Everything that defines one run (and the settings a resumed run must share).

    :param env_id: The environment id
    :param algo: An algorithm rl_zoo3 knows (``"reinforce"``, ``"ppo"``, ``"a2c"``, ``"trpo"``, ...)
    :param seed: The seed (model, training and evaluation environments)
    :param budget: Training environment steps
    :param eval_freq: Evaluate every this many environment steps
    :param n_eval_episodes: Episodes per evaluation (deterministic, and again stochastic)
    :param config_path: The zoo yml (None: :func:`~sb3_reinforce.lab.compare.experiment.read_entry`'s default)
    """

    env_id: str
    algo: str
    seed: int
    budget: int
    eval_freq: int
    n_eval_episodes: int
    config_path: str | None = None

    @property
    def name(self) -> str:
        """File stem of this run's outputs."""
        return f"{self.algo}_seed{self.seed}"


class ComparisonEvalCallback(BaseCallback):
    """
    Evaluate every ``eval_freq`` steps (and before training), deterministic then stochastic, appending a row to
    ``csv_path``. Training time excludes evaluations; peak memory is :func:`process_tree_rss_mb`.

    :param spec: The run being evaluated
    :param eval_env: The evaluation environment (synchronized with a ``VecNormalize`` training env if any)
    :param csv_path: Where the rows are appended
    :param progress: Called with the environment steps done so far after each evaluation (or None)
    :param checkpoint: Saves the run after each evaluation (or None: no checkpoints)
    :param resumed: The counters of the checkpoint this run resumes from (or None: a new run, evaluated before training)
    :param heartbeat: Called at every step (or None); it may raise to stop the run (its last checkpoint kept)
    :param episode_batch: Plays the deterministic episodes side by side, same returns (None: ``evaluate_policy``)
    """

    def __init__(
        self,
        spec: RunSpec,
        eval_env: VecEnv,
        csv_path: Path,
        progress: Any = None,
        checkpoint: "Checkpoint | None" = None,
        resumed: dict[str, Any] | None = None,
        heartbeat: Callable[[], None] | None = None,
        episode_batch: EpisodeBatch | None = None,
    ) -> None:
        super().__init__()
        self.episode_batch = episode_batch
        self.heartbeat = heartbeat
        self.spec = spec
        self.eval_env = eval_env
        self.csv_path = csv_path
        self.progress = progress
        self.checkpoint = checkpoint
        self.resumed = resumed
        self.eval_index = 0
        self.next_eval = 0
        self.last_eval_steps = -1
        self.n_episodes = 0
        self.eval_time = 0.0
        self.start_time = 0.0
        self.train_time_before = 0.0  # training seconds of the runs this one resumes
        self.process = psutil.Process()
        self.peak_rss_mb = 0.0
        if resumed is not None:
            self.eval_index = int(resumed["eval_index"])
            self.next_eval = self.eval_index * spec.eval_freq
            self.last_eval_steps = int(resumed["steps"])
            self.n_episodes = int(resumed["episodes"])
            self.train_time_before = float(resumed["train_time_s"])
            self.peak_rss_mb = float(resumed["peak_rss_mb"])

    def _on_training_start(self) -> None:
        self.start_time = time.perf_counter()
        if self.resumed is None:
            self._evaluate()

    def training_time(self) -> float:
        """Wall-clock seconds of training so far, evaluations excluded (those before a resume included)."""
        return self.train_time_before + time.perf_counter() - self.start_time - self.eval_time

    def counters(self) -> dict[str, Any]:
        """What a resumed run needs to go on counting: the next evaluation, steps, episodes, time, memory."""
        return dict(
            eval_index=self.eval_index,
            steps=self.num_timesteps,
            episodes=self.n_episodes,
            train_time_s=self.training_time(),
            peak_rss_mb=self.peak_rss_mb,
        )

    def _on_step(self) -> bool:
        if self.heartbeat is not None:
            self.heartbeat()
        self.n_episodes += sum(1 for info in self.locals["infos"] if "episode" in info)
        if self.num_timesteps >= self.next_eval:
            self._evaluate()
        return True

    def _evaluate(self) -> None:
        eval_start = time.perf_counter()
        self.peak_rss_mb = max(self.peak_rss_mb, process_tree_rss_mb(self.process))
        sync_envs_normalization(self.training_env, self.eval_env)
        results = []
        for deterministic in (True, False):
            if deterministic and self.episode_batch is not None:
                sync_envs_normalization(self.training_env, self.episode_batch.copies)
                rewards: list[float] = self.episode_batch.evaluate(self.model)
            else:
                rewards, _ = evaluate_policy(  # type: ignore[assignment]
                    self.model,
                    self.eval_env,
                    n_eval_episodes=self.spec.n_eval_episodes,
                    deterministic=deterministic,
                    return_episode_rewards=True,
                )
            results += [float(np.mean(rewards)), float(np.std(rewards))]
        self.eval_time += time.perf_counter() - eval_start
        row = [
            self.spec.env_id,
            self.spec.algo,
            self.spec.seed,
            self.eval_index,
            self.num_timesteps,
            self.n_episodes,
            round(self.training_time(), 3),
            *results,
            round(self.peak_rss_mb, 1),
        ]
        with self.csv_path.open("a", newline="") as f:
            csv.writer(f).writerow(row)
        self.eval_index += 1
        self.last_eval_steps = self.num_timesteps
        self.next_eval = self.eval_index * self.spec.eval_freq
        if self.checkpoint is not None and 0 < self.num_timesteps < self.spec.budget:
            save_start = time.perf_counter()
            self.checkpoint.save(self.model, self.counters())
            self.eval_time += time.perf_counter() - save_start  # not training time either
        if self.progress is not None:
            self.progress(self.num_timesteps)


def process_tree_rss_mb(process: psutil.Process) -> float:
    """Memory (MiB) of ``process`` (RSS) and its descendants (USS: shared pages left out, so a lower bound)."""
    total = process.memory_info().rss
    for child in process.children(recursive=True):
        with contextlib.suppress(psutil.NoSuchProcess, psutil.AccessDenied):
            total += child.memory_full_info().uss
    return total / 2**20


def process_tree_cpu_s(process: psutil.Process | None = None) -> float:
    """CPU seconds (user + system) of ``process`` (default: this one) and its descendants, ended ones once waited for."""
    process = process or psutil.Process()
    total = 0.0
    for member in [process, *process.children(recursive=True)]:
        with contextlib.suppress(psutil.NoSuchProcess):
            times = member.cpu_times()
            total += times.user + times.system + times.children_user + times.children_system
    return total


#: ``VecNormalize``'s running statistics, saved with a checkpoint.
_RUNNING_STATISTICS = ("obs_rms", "ret_rms")


class Checkpoint:
    """
    A run's checkpoint in ``per_run/``: ``<name>.checkpoint.zip``, ``<name>.checkpoint_vecnormalize.pkl`` and
    ``<name>.checkpoint.json``, each written whole then renamed, the JSON last: without it the checkpoint is ignored.

    :param runs_dir: The comparison's ``per_run/`` folder
    :param spec: The run
    :param hyperparams: The run's zoo entry as in its summary (a checkpoint made with other values is not resumed)
    :param vec_env: The kind of vectorized training environment of this process (``"dummy"`` or ``"subproc"``)
    :param cpu_at_start: :func:`process_tree_cpu_s` when the run started in this process (counted from there)
    :param device: Where the model computes in this process (PyTorch's device name, as given)
    """

    def __init__(
        self,
        runs_dir: Path,
        spec: RunSpec,
        hyperparams: dict[str, str],
        vec_env: str = "dummy",
        cpu_at_start: float = 0.0,
        device: str = "cpu",
    ) -> None:
        self.cpu_at_start = cpu_at_start
        self.spec = spec
        self.hyperparams = hyperparams
        self.vec_envs = [vec_env]
        self.devices = [device]
        self.model_path = runs_dir / f"{spec.name}.checkpoint.zip"
        self.vecnormalize_path = runs_dir / f"{spec.name}.checkpoint_vecnormalize.pkl"
        self.state_path = runs_dir / f"{spec.name}.checkpoint.json"
        self.cpu_time_before = 0.0
        self.resumed_at_steps: list[int] = []

    def save(self, model: BaseAlgorithm, counters: dict[str, Any]) -> None:
        """Save the model and the counters (the JSON is removed first and written last)."""
        self.state_path.unlink(missing_ok=True)
        temporary_model = self.model_path.with_suffix(".tmp.zip")
        save_with_random_state(model, temporary_model)  # a resumed run draws what an uninterrupted one draws
        os.replace(temporary_model, self.model_path)
        vecnormalize = model.get_vec_normalize_env()
        if vecnormalize is not None:
            # obs_rms exists only with norm_obs=True
            statistics = {name: vecnormalize.__dict__[name] for name in _RUNNING_STATISTICS if name in vecnormalize.__dict__}
            write_replacing(self.vecnormalize_path, pickle.dumps(statistics))
        state = dict(
            spec=self.spec.__dict__,
            hyperparams=self.hyperparams,
            counters=counters,
            cpu_time_s=self.cpu_time_s(),
            resumed_at_steps=self.resumed_at_steps,
            vec_envs=self.vec_envs,
            devices=self.devices,
        )
        write_replacing(self.state_path, json.dumps(state, indent=2).encode())

    def cpu_time_s(self) -> float:
        """CPU seconds of the run so far, in this process (environment processes included) and those it resumes."""
        return self.cpu_time_before + process_tree_cpu_s() - self.cpu_at_start

    def exists(self) -> bool:
        """Whether a complete checkpoint (the model and, written last, the JSON) is there, of whichever settings."""
        return self.state_path.exists() and self.model_path.exists()

    def load_state(self) -> dict[str, Any] | None:
        """The saved state, or None without a complete checkpoint of this very run (other settings, or a damaged file)."""
        if not self.exists():
            return None
        try:
            state = json.loads(self.state_path.read_text())
        except json.JSONDecodeError:
            return None
        # Older checkpoints without hyperparameters match them
        same_run = state.get("spec") == self.spec.__dict__ and state.get("hyperparams", self.hyperparams) == self.hyperparams
        return state if same_run else None

    def restore(self, model: BaseAlgorithm, state: dict[str, Any]) -> BaseAlgorithm:
        """
        The model of the checkpoint, on ``model``'s training env with its ``VecNormalize`` statistics restored.

        :param model: The freshly built model of the run (its env is reused)
        :param state: :meth:`load_state`'s result
        :return: The restored model
        """
        env = model.get_env()
        restored = load_with_random_state(type(model), self.model_path, env=env, device=model.device)
        vecnormalize = restored.get_vec_normalize_env()
        if vecnormalize is not None:
            with self.vecnormalize_path.open("rb") as f:
                statistics = pickle.load(f)  # written by this run (on a worker of its cluster), see save()
            vecnormalize.__dict__.update(statistics)
        self.cpu_time_before = float(state["cpu_time_s"])
        self.resumed_at_steps = [*state["resumed_at_steps"], int(restored.num_timesteps)]
        # Older checkpoints without the kind all used DummyVecEnv
        earlier = state.get("vec_envs", ["dummy"] * (1 + len(state["resumed_at_steps"])))
        self.vec_envs = [*earlier, self.vec_envs[-1]]
        # Older checkpoints without the device all trained on the CPU
        self.devices = [*state.get("devices", ["cpu"] * len(earlier)), self.devices[-1]]
        return restored

    def delete(self) -> None:
        """Remove the checkpoint's files (the run is finished)."""
        for path in (self.state_path, self.model_path, self.vecnormalize_path):
            path.unlink(missing_ok=True)


def write_replacing(path: Path, data: bytes) -> None:
    """Write ``path`` whole, then rename it into place: an interruption leaves the old file or the new one."""
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)


def _keep_rows_before(csv_path: Path, eval_index: int) -> None:
    """Drop the CSV rows of evaluations at or after ``eval_index`` (made after the checkpoint a run resumes)."""
    with csv_path.open(newline="") as f:
        rows = list(csv.reader(f))
    column = RESULT_COLUMNS.index("eval_index")
    kept = [rows[0]] + [row for row in rows[1:] if int(row[column]) < eval_index]
    buffer = io.StringIO()
    csv.writer(buffer).writerows(kept)
    write_replacing(csv_path, buffer.getvalue().encode())


def code_version() -> dict[str, Any]:
    """
    The package version and, in a git checkout, the commit and whether tracked files differ (taken in the run's worker).

    :return: ``{"sb3_reinforce": version, "git_commit": hash or None, "git_dirty": bool or None}``
    """
    package_dir = Path(__file__).resolve().parent

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", *args], cwd=package_dir, capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    status = None if commit is None else git("status", "--porcelain", "--untracked-files=no")
    return {"sb3_reinforce": __version__, "git_commit": commit, "git_dirty": None if status is None else status != ""}


def exploration_noise_to_policy_device(model: BaseAlgorithm) -> None:
    """
    Move gSDE's exploration matrices to the policy's device, values unchanged. SB3 draws them on the CPU as plain
    attributes that ``policy.to(device)`` leaves behind, and the evaluation before the first rollout would mix devices.

    :param model: A built or loaded model (anything without gSDE is left as it is)
    """
    distribution = getattr(model.policy, "action_dist", None)
    if not isinstance(distribution, StateDependentNoiseDistribution):
        return
    for name in ("exploration_mat", "exploration_matrices"):
        matrix = getattr(distribution, name, None)
        if isinstance(matrix, th.Tensor):
            setattr(distribution, name, matrix.to(model.policy.device))


def run(
    spec: RunSpec,
    out_dir: Path,
    progress: Any = None,
    vec_env: str = "dummy",
    heartbeat: Callable[[], None] | None = None,
    device: str = "cpu",
) -> dict[str, Any]:
    """
    Train and evaluate one run into ``out_dir/per_run/<algo>_seed<seed>.csv`` (appended per evaluation) and, once done,
    ``.json`` (its summary). A run with a JSON is finished; a matching checkpoint is resumed; else the run starts over.

    :param spec: The run
    :param out_dir: The comparison's output folder
    :param progress: Called with the steps done so far after each evaluation (or None)
    :param vec_env: ``"dummy"`` (in this process) or ``"subproc"`` (one process each); a run may resume with the other
    :param heartbeat: Called at every training step (or None); it may raise to stop the run, whose last checkpoint stays
    :param device: PyTorch device of the networks; a run may resume on another (only CPU random generators are
        checkpointed: a GPU or cross-device run is not reproducible bit for bit)
    :return: The summary written to the JSON file
    """
    cpu_at_start = process_tree_cpu_s()
    th.set_num_threads(1)
    version = code_version()
    runs_dir = out_dir / PER_RUN_DIR
    runs_dir.mkdir(parents=True, exist_ok=True)
    csv_path = runs_dir / f"{spec.name}.csv"

    with tempfile.TemporaryDirectory(prefix=f"{spec.name}-zoo-") as zoo_folder:
        config = None if spec.config_path is None else Path(spec.config_path)
        built = build_run(
            spec.algo,
            spec.env_id,
            spec.seed,
            spec.budget,
            Path(zoo_folder),
            config,
            vec_env,
            device=device,
            eval_copies=spec.n_eval_episodes if spec.n_eval_episodes > 1 else 0,
        )
        model, eval_env = built.model, built.eval_env
        batch = None if built.eval_copies is None else episode_batch(eval_env, built.eval_copies)
        hyperparams = {key: str(value) for key, value in built.entry.hyperparams.items()}
        # Off-policy runs are not checkpointed: model.save leaves their replay buffer out
        checkpoint = (
            None
            if isinstance(model, OffPolicyAlgorithm)
            else Checkpoint(runs_dir, spec, hyperparams, vec_env, cpu_at_start, device)
        )
        state = checkpoint.load_state() if checkpoint is not None and csv_path.exists() else None
        resumed = None
        if checkpoint is not None and state is not None:
            model = checkpoint.restore(model, state)
            resumed = state["counters"]
            _keep_rows_before(csv_path, int(resumed["eval_index"]))
        else:
            with csv_path.open("w", newline="") as f:
                csv.writer(f).writerow(RESULT_COLUMNS)
        exploration_noise_to_policy_device(model)
        callback = ComparisonEvalCallback(spec, eval_env, csv_path, progress, checkpoint, resumed, heartbeat, batch)
        # Resumed: the steps left, on the restored step count (the schedules go on from where they were)
        model.learn(
            total_timesteps=spec.budget - model.num_timesteps,
            callback=[*built.callbacks, callback],
            reset_num_timesteps=resumed is None,
        )
        train_time = callback.training_time()
        if callback.last_eval_steps < model.num_timesteps:
            callback._evaluate()  # the final point, at the end of the budget
        built.train_env.close()
        eval_env.close()
        if batch is not None:
            batch.copies.close()
    summary = dict(
        spec=spec.__dict__,
        code_version=version,
        hyperparams_source=str(built.entry.source),
        hyperparams=hyperparams,
        steps=int(model.num_timesteps),
        train_time_s=round(train_time, 3),
        steps_per_s=round(model.num_timesteps / train_time, 1),
        peak_rss_mb=round(callback.peak_rss_mb, 1),
        # CPU seconds since the run started here (environment processes included), plus those of the runs it resumes
        cpu_time_s=round(process_tree_cpu_s() - cpu_at_start if checkpoint is None else checkpoint.cpu_time_s(), 1),
        vec_envs=[vec_env] if checkpoint is None else checkpoint.vec_envs,
        devices=[device] if checkpoint is None else checkpoint.devices,
    )
    if checkpoint is not None and checkpoint.resumed_at_steps:
        summary["resumed_at_steps"] = checkpoint.resumed_at_steps
    (runs_dir / f"{spec.name}.json").write_text(json.dumps(summary, indent=2))
    if checkpoint is not None:
        checkpoint.delete()
    return summary
