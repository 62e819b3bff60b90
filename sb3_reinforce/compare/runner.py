"""
One run of the comparison: one algorithm, one seed. It trains on ``n_envs`` training environments and, every
``eval_freq`` environment steps (all training environments counted), evaluates on a separate evaluation
environment: ``n_eval_episodes`` episodes with deterministic actions, then as many with sampled actions.
Each evaluation is appended at once to the run's CSV, so an interrupted run keeps what it measured.
"""

import csv
import json
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import psutil
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecEnv, sync_envs_normalization

from sb3_reinforce.compare.experiment import build_run
from sb3_reinforce.compare.report import PER_RUN_DIR
from sb3_reinforce.version import __version__

__all__ = ["RESULT_COLUMNS", "ComparisonEvalCallback", "RunSpec", "code_version", "run"]

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
    :param config_path: The algorithm's zoo yml (None: the default one, as
        :func:`~sb3_reinforce.compare.experiment.read_entry`)
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
    Evaluate every ``eval_freq`` environment steps (and before training) on a separate environment, with
    deterministic and with sampled actions, and append a row to ``csv_path``. Training wall-clock time
    excludes the evaluations; peak memory is the resident set size (RSS) of this process.

    :param spec: The run being evaluated
    :param eval_env: The evaluation environment (synchronized with a ``VecNormalize`` training env if any)
    :param csv_path: Where the rows are appended
    :param progress: Called with the environment steps done so far after each evaluation (or None)
    """

    def __init__(self, spec: RunSpec, eval_env: VecEnv, csv_path: Path, progress: Any = None) -> None:
        super().__init__()
        self.spec = spec
        self.eval_env = eval_env
        self.csv_path = csv_path
        self.progress = progress
        self.eval_index = 0
        self.next_eval = 0
        self.last_eval_steps = -1
        self.n_episodes = 0
        self.eval_time = 0.0
        self.start_time = 0.0
        self.process = psutil.Process()
        self.peak_rss_mb = 0.0

    def _on_training_start(self) -> None:
        self.start_time = time.perf_counter()
        self._evaluate()

    def training_time(self) -> float:
        """Wall-clock seconds of training so far, evaluations excluded."""
        return time.perf_counter() - self.start_time - self.eval_time

    def _on_step(self) -> bool:
        self.n_episodes += sum(1 for info in self.locals["infos"] if "episode" in info)
        if self.num_timesteps >= self.next_eval:
            self._evaluate()
        return True

    def _evaluate(self) -> None:
        eval_start = time.perf_counter()
        self.peak_rss_mb = max(self.peak_rss_mb, self.process.memory_info().rss / 2**20)
        sync_envs_normalization(self.training_env, self.eval_env)
        results = []
        for deterministic in (True, False):
            rewards, _ = evaluate_policy(
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
        if self.progress is not None:
            self.progress(self.num_timesteps)


def code_version() -> dict[str, Any]:
    """
    What code a run used: the package version and, in a git checkout, the commit and whether the tracked files
    differed from it. Taken when the run starts (each run is a fresh process, so commits made while a
    comparison runs reach its later runs, and their JSON files say so).

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


def run(spec: RunSpec, out_dir: Path, progress: Any = None) -> dict[str, Any]:
    """
    Train and evaluate one run; write ``out_dir/per_run/<algo>_seed<seed>.csv`` (one row per evaluation,
    appended as it goes) and, once finished, ``<algo>_seed<seed>.json`` (the run's summary). A run with a
    JSON file is finished; anything else is started over.

    :param spec: The run
    :param out_dir: The comparison's output folder
    :param progress: Called with the steps done so far after each evaluation (or None)
    :return: The summary written to the JSON file
    """
    th.set_num_threads(1)
    version = code_version()
    runs_dir = out_dir / PER_RUN_DIR
    runs_dir.mkdir(parents=True, exist_ok=True)
    csv_path = runs_dir / f"{spec.name}.csv"
    with csv_path.open("w", newline="") as f:
        csv.writer(f).writerow(RESULT_COLUMNS)

    with tempfile.TemporaryDirectory(prefix=f"{spec.name}-zoo-") as zoo_folder:
        config = None if spec.config_path is None else Path(spec.config_path)
        built = build_run(spec.algo, spec.env_id, spec.seed, spec.budget, Path(zoo_folder), config)
        model, eval_env = built.model, built.eval_env
        callback = ComparisonEvalCallback(spec, eval_env, csv_path, progress)
        model.learn(total_timesteps=spec.budget, callback=[*built.callbacks, callback])
        train_time = callback.training_time()
        if callback.last_eval_steps < model.num_timesteps:
            callback._evaluate()  # the final point, at the end of the budget
        built.train_env.close()
        eval_env.close()
    summary = dict(
        spec=spec.__dict__,
        code_version=version,
        hyperparams_source=str(built.entry.source),
        hyperparams={key: str(value) for key, value in built.entry.hyperparams.items()},
        steps=int(model.num_timesteps),
        train_time_s=round(train_time, 3),
        steps_per_s=round(model.num_timesteps / train_time, 1),
        peak_rss_mb=round(callback.peak_rss_mb, 1),
        # CPU seconds of this process (imports, training and evaluations): what the run costs on an idle core
        cpu_time_s=round(sum(psutil.Process().cpu_times()[:2]), 1),
    )
    (runs_dir / f"{spec.name}.json").write_text(json.dumps(summary, indent=2))
    return summary
