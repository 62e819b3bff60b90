"""
One run of the comparison (one algorithm, one seed): resume it from its checkpoint if it has one, train it with its
evaluation callback, and summarize it. Every ``eval_freq`` steps the callback evaluates ``n_eval_episodes``
deterministic then as many stochastic episodes on a separate environment, appends the evaluation to the run's CSV and
the training's diagnostics to its training log, and saves a checkpoint. The run is built by
:func:`~sb3_reinforce.lab.compare.experiment.build_run`; its files are the comparison folder's
(:mod:`sb3_reinforce.lab.compare.folder`). Off-policy runs are not checkpointed: ``model.save`` omits the replay buffer.
"""

import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import psutil
import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.distributions import StateDependentNoiseDistribution

from sb3_reinforce.lab.compare.evaluation import Evaluator
from sb3_reinforce.lab.compare.experiment import build_run
from sb3_reinforce.lab.compare.folder import Checkpoint, ComparisonFolder, RunSpec
from sb3_reinforce.lab.provenance import code_version, system_info
from sb3_reinforce.lab.resource_use import process_tree_cpu_s, process_tree_rss_mb

__all__ = ["ComparisonEvalCallback", "exploration_noise_to_policy_device", "run"]


class ComparisonEvalCallback(BaseCallback):
    """
    Evaluate every ``eval_freq`` steps (and before training), appending a row to the run's CSV and saving its
    checkpoint. Training time excludes evaluations; peak memory is :func:`process_tree_rss_mb`. A run with
    ``spec.stop_at`` ends at its first deterministic evaluation after training started at or above it. After ``learn``,
    :meth:`evaluate_if_trained_since` makes the final evaluation.

    :param spec: The run being evaluated
    :param evaluator: Evaluates the model (deterministic, then sampled actions)
    :param folder: The comparison's folder, where the evaluations are appended
    :param progress: Called with the environment steps done so far after each evaluation (or None)
    :param checkpoint: Saves the run after each evaluation (or None: no checkpoints)
    :param resumed: The counters of the checkpoint this run resumes from (or None: a new run, evaluated before training)
    :param heartbeat: Called at every step (or None); it may raise to stop the run (its last checkpoint kept)
    """

    def __init__(
        self,
        spec: RunSpec,
        evaluator: Evaluator,
        folder: ComparisonFolder,
        progress: Any = None,
        checkpoint: Checkpoint | None = None,
        resumed: dict[str, Any] | None = None,
        heartbeat: Callable[[], None] | None = None,
    ) -> None:
        super().__init__()
        self.spec = spec
        self.evaluator = evaluator
        self.folder = folder
        self.progress = progress
        self.checkpoint = checkpoint
        self.resumed = resumed
        self.heartbeat = heartbeat
        self.eval_index = 0
        self.next_eval = 0
        self.last_eval_steps = -1
        self.n_episodes = 0
        self.eval_time = 0.0
        self.reached_stop_at = False
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
        return not self.reached_stop_at  # False ends learn()

    def training_diagnostics(self) -> dict[str, float]:
        """
        What the training looks like at an evaluation: the logger's latest ``train/*`` numbers (the last update's:
        losses, entropy, the Gaussian's std, ...; none before the first update) and the mean return and length of the
        last training episodes (SB3's ``ep_info_buffer``, ``stats_window_size`` of them).
        """
        values = {
            key: float(value)
            for key, value in self.model.logger.name_to_value.items()
            if key.startswith("train/") and isinstance(value, int | float | np.number)
        }
        episodes = self.model.ep_info_buffer
        if episodes:
            values["rollout/ep_rew_mean"] = float(np.mean([episode["r"] for episode in episodes]))
            values["rollout/ep_len_mean"] = float(np.mean([episode["l"] for episode in episodes]))
        return values

    def evaluate_if_trained_since(self) -> None:
        """The final evaluation, at the end of the budget, unless the last one was made at the last step or stopped the run."""
        if self.last_eval_steps < self.num_timesteps and not self.reached_stop_at:
            self._evaluate()

    def _evaluate(self) -> None:
        eval_start = time.perf_counter()
        self.peak_rss_mb = max(self.peak_rss_mb, process_tree_rss_mb(self.process))
        results = self.evaluator.evaluate(self.model, self.training_env)
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
        self.folder.append_evaluation(self.spec, row)
        record = dict(eval_index=self.eval_index, steps=self.num_timesteps, **self.training_diagnostics())
        self.folder.append_training_log(self.spec, record)
        # not on the untrained policy's evaluation: it can score by chance, and the tables leave it out
        stop_at = self.spec.stop_at
        self.reached_stop_at = stop_at is not None and self.num_timesteps > 0 and results[0] >= stop_at
        self.eval_index += 1
        self.last_eval_steps = self.num_timesteps
        self.next_eval = self.eval_index * self.spec.eval_freq
        if self.checkpoint is not None and 0 < self.num_timesteps < self.spec.budget:
            save_start = time.perf_counter()
            self.checkpoint.save(self.model, self.counters())
            self.eval_time += time.perf_counter() - save_start  # not training time either
        if self.progress is not None:
            self.progress(self.num_timesteps)


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


def _history(checkpoint: Checkpoint | None, cpu_at_start: float, vec_env: str, device: str) -> dict[str, Any]:
    """
    CPU seconds of the run, its kinds of environment processes and devices (one per part), and where it was resumed:
    the steps it resumed at and the systems of its parts (None for a part that did not record its own).
    """
    if checkpoint is None:
        return dict(cpu_time_s=round(process_tree_cpu_s() - cpu_at_start, 1), vec_envs=[vec_env], devices=[device])
    history = dict(cpu_time_s=round(checkpoint.cpu_time_s(), 1), vec_envs=checkpoint.vec_envs, devices=checkpoint.devices)
    if checkpoint.resumed_at_steps:
        history |= dict(resumed_at_steps=checkpoint.resumed_at_steps, systems=checkpoint.systems)
    return history


def run(
    spec: RunSpec,
    out_dir: Path,
    progress: Any = None,
    vec_env: str = "dummy",
    heartbeat: Callable[[], None] | None = None,
    device: str = "cpu",
) -> dict[str, Any]:
    """
    Train and evaluate one run into the comparison folder ``out_dir``: its CSV (appended per evaluation) and, once
    done, its summary. A finished run has a summary; a matching checkpoint is resumed; else the run starts over.

    :param spec: The run
    :param out_dir: The comparison's folder
    :param progress: Called with the steps done so far after each evaluation (or None)
    :param vec_env: ``"dummy"``, ``"subproc"`` or ``"envpool"``; a run may resume with another
    :param heartbeat: Called at every training step (or None); it may raise to stop the run, whose last checkpoint stays
    :param device: PyTorch device of the networks; a run may resume on another (only CPU random generators are
        checkpointed: a GPU or cross-device run is not reproducible bit for bit)
    :return: The summary written
    """
    cpu_at_start = process_tree_cpu_s()
    load_at_start = os.getloadavg()[0]
    th.set_num_threads(1)
    provenance = dict(code_version=code_version(), system=system_info())  # taken where and when the run starts
    folder = ComparisonFolder(out_dir)
    with tempfile.TemporaryDirectory(prefix=f"{spec.name}-zoo-") as zoo_folder:
        config = None if spec.config_path is None else Path(spec.config_path)
        run_args = (spec.algo, spec.env_id, spec.seed, spec.budget, Path(zoo_folder), config, vec_env)
        built = build_run(*run_args, device=device, n_eval_episodes=spec.n_eval_episodes)
        hyperparams = {key: str(value) for key, value in built.entry.hyperparams.items()}
        system = provenance["system"]
        built.model, checkpoint, resumed = folder.resume(spec, built.model, hyperparams, vec_env, cpu_at_start, device, system)
        exploration_noise_to_policy_device(built.model)
        callback = ComparisonEvalCallback(spec, built.evaluator, folder, progress, checkpoint, resumed, heartbeat)
        # Resumed: the steps left, on the restored step count (the schedules go on from where they were)
        steps_left = spec.budget - built.model.num_timesteps
        built.model.learn(steps_left, [*built.callbacks, callback], reset_num_timesteps=resumed is None)
        train_time = callback.training_time()
        callback.evaluate_if_trained_since()
        built.close()
    steps = int(built.model.num_timesteps)
    summary = dict(
        spec=spec.identity(),
        **provenance,
        hyperparams_source=str(built.entry.source),
        zoo_entry=built.entry.fallback or spec.env_id,  # "default": the file had no entry for the env
        hyperparams=hyperparams,
        steps=steps,
        train_time_s=round(train_time, 3),
        steps_per_s=round(steps / train_time, 1),
        load_1min=[round(load_at_start, 2), round(os.getloadavg()[0], 2)],  # the machine's, at the start and the end
        peak_rss_mb=round(callback.peak_rss_mb, 1),
        # CPU seconds since the run started here (environment processes included), plus those of the runs it resumes
        **_history(checkpoint, cpu_at_start, vec_env, device),
    )
    folder.write_summary(spec, summary)
    if checkpoint is not None:
        checkpoint.delete()
    return summary
