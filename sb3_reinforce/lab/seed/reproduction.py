"""
The seed reproduction: the seed's agent trained for a fixed number of episodes, one row per training episode.

    python -m sb3_reinforce.lab.seed.reproduction --env LunarLander-v3 --episodes 5000 --seeds 3 --out DIR

Seeds run on a local Dask cluster and write ``DIR/episodes_seedN.csv``; finished seeds are skipped on a rerun.
A seed stopped early (``--max-steps``, ``--max-episode-steps``) keeps its episodes and writes why into
``episodes_seedN.stopped`` (JSON); it counts as done on a rerun with the same settings.
"""

import argparse
import csv
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
import pandas as pd
import psutil
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor

from sb3_reinforce.lab.extras import check_env_id
from sb3_reinforce.lab.resource_use import process_tree_rss_mb
from sb3_reinforce.lab.seed.envs import make_seed_env
from sb3_reinforce.lab.seed.presets import seed_hyperparams
from sb3_reinforce.reinforce import REINFORCE
from sb3_reinforce.reinforce.buffers import RolloutLimitError

if TYPE_CHECKING:
    from sb3_reinforce.lab.cluster import RunChannel

__all__ = ["EPISODE_COLUMNS", "RewardFloor", "build_parser", "main", "run_seed"]

EPISODE_COLUMNS = ["env", "seed", "episode", "steps", "wall_time_s", "episode_return", "episode_length", "peak_rss_mb"]


class RewardFloor(gym.Wrapper):
    """
    Truncate an episode once its summed reward falls below ``floor`` (the seed's LunarLander script used -250).

    :param env: The environment to wrap
    :param floor: The summed-reward floor
    """

    def __init__(self, env: gym.Env, floor: float) -> None:
        super().__init__(env)
        self.floor = floor
        self._sum = 0.0

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        self._sum = 0.0
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._sum += float(reward)
        if self._sum < self.floor and not terminated:
            truncated = True
        return obs, float(reward), terminated, truncated, info


class _EpisodeRecorder(BaseCallback):
    """Append one CSV row per finished training episode, and stop after ``n_episodes`` episodes."""

    def __init__(
        self,
        path: Path,
        env_id: str,
        seed: int,
        n_episodes: int,
        start_episode: int = 0,
        on_episodes: Callable[[int], None] | None = None,
    ) -> None:
        super().__init__()
        self.on_episodes = on_episodes
        self.path = path
        self.env_id = env_id
        self.seed = seed
        self.n_episodes = n_episodes
        self.episode = start_episode
        self.start_time = time.perf_counter()
        self.process = psutil.Process()
        self.peak_rss_mb = 0.0

    def _on_step(self) -> bool:
        rows = []
        for info in self.locals["infos"]:
            if "episode" in info:
                self.episode += 1
                self.peak_rss_mb = max(self.peak_rss_mb, process_tree_rss_mb(self.process))
                rows.append(
                    [
                        self.env_id,
                        self.seed,
                        self.episode,
                        self.num_timesteps,
                        round(time.perf_counter() - self.start_time, 3),
                        float(info["episode"]["r"]),
                        int(info["episode"]["l"]),
                        round(self.peak_rss_mb, 1),
                    ]
                )
        if rows:
            with self.path.open("a", newline="") as f:
                csv.writer(f).writerows(rows)
            if self.on_episodes is not None:
                self.on_episodes(self.num_timesteps)
        return self.episode < self.n_episodes


def _make_env(env_id: str, reward_floor: float | None) -> gym.Env:
    env = make_seed_env(env_id)
    if reward_floor is not None:
        env = RewardFloor(env, reward_floor)
    return Monitor(env)


def run_seed(
    env_id: str,
    seed: int,
    n_episodes: int,
    out_dir: Path,
    reward_floor: float | None,
    max_steps: int | None = None,
    max_episode_steps: int = 1_000_000,
    on_episodes: Callable[[int], None] | None = None,
) -> None:
    """
    Train the seed's agent for ``n_episodes`` episodes, writing them to ``out_dir / f"episodes_seed{seed}.csv"``.

    :param env_id: A registered Gymnasium env id
    :param seed: The random seed (model, env, torch)
    :param n_episodes: Number of training episodes
    :param out_dir: Output folder
    :param reward_floor: End an episode when its summed reward falls below this (None: never)
    :param max_steps: Stop at the first update after this many training steps (None: no cap)
    :param max_episode_steps: Stop when one episode reaches this many steps (the model's ``max_rollout_steps``)
    :param on_episodes: Called with the training steps so far each time episodes were appended (or None)
    """
    th.set_num_threads(1)
    path = out_dir / f"episodes_seed{seed}.csv"
    stopped = _stopped_path(path)
    stopped.unlink(missing_ok=True)
    # A partial file (interrupted run) cannot be continued: start over
    with path.open("w", newline="") as f:
        csv.writer(f).writerow(EPISODE_COLUMNS)
    model = REINFORCE(
        env=_make_env(env_id, reward_floor),
        seed=seed,
        device="cpu",
        max_rollout_steps=max_episode_steps,
        **seed_hyperparams(env_id),
    )
    recorder = _EpisodeRecorder(path, env_id, seed, n_episodes, on_episodes=on_episodes)
    try:
        model.learn(total_timesteps=10**9 if max_steps is None else max_steps, callback=recorder)
    except RolloutLimitError:
        reason = f"episode {recorder.episode + 1} did not end within {max_episode_steps:,} steps (--max-episode-steps)"
    else:
        reason = (
            "" if recorder.episode >= n_episodes else f"the step cap of {max_steps or 0:,} steps (--max-steps) was reached"
        )
    if reason:
        text = f"seed {seed} stopped after {recorder.episode:,} of {n_episodes:,} episodes: {reason}"
        settings = _settings(n_episodes, max_steps, max_episode_steps)
        stopped.write_text(json.dumps(dict(reason=text, settings=settings), indent=2) + "\n")


def _stopped_path(path: Path) -> Path:
    return path.with_suffix(".stopped")


def _settings(n_episodes: int, max_steps: int | None, max_episode_steps: int) -> dict[str, Any]:
    return dict(episodes=n_episodes, max_steps=max_steps, max_episode_steps=max_episode_steps)


def _finished(path: Path, n_episodes: int, max_steps: int | None = None, max_episode_steps: int = 1_000_000) -> bool:
    stopped = _stopped_path(path)
    if stopped.exists():
        # Stopped early: done only for the same settings
        return bool(json.loads(stopped.read_text())["settings"] == _settings(n_episodes, max_steps, max_episode_steps))
    if not path.exists():
        return False
    try:
        episodes = pd.read_csv(path)["episode"]
    except (pd.errors.EmptyDataError, KeyError):
        return False
    return len(episodes) > 0 and int(episodes.max()) >= n_episodes


#: Seconds between two sendings of a seed's episodes back to the command.
SEND_EVERY_S = 5.0


def _run_seed_on_worker(
    channel: "RunChannel",
    env_id: str,
    seed: int,
    n_episodes: int,
    reward_floor: float | None,
    max_steps: int | None,
    max_episode_steps: int,
) -> None:
    """On a Dask worker: :func:`run_seed`, its episodes sent back every ``SEND_EVERY_S`` seconds."""
    next_send = time.monotonic() + SEND_EVERY_S

    def on_episodes(steps: int) -> None:
        nonlocal next_send
        channel.check_stop()
        if time.monotonic() >= next_send:
            channel.send(steps)
            next_send = time.monotonic() + SEND_EVERY_S

    run_seed(env_id, seed, n_episodes, channel.folder, reward_floor, max_steps, max_episode_steps, on_episodes)


def build_parser() -> argparse.ArgumentParser:
    """The ``seed`` command's argument parser."""
    parser = argparse.ArgumentParser(
        prog="sb3-reinforce seed",
        description="Train the seed's agent for a number of episodes (x axis: episodes).",
    )
    parser.add_argument("--env", default="LunarLander-v3", help="Gymnasium env id (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=5000, help="training episodes per seed, >= 1 (default: %(default)s)")
    parser.add_argument("--seeds", type=int, default=3, help="number of seeds: 0, 1, ..., seeds-1 (default: %(default)s)")
    parser.add_argument(
        "--reward-floor",
        type=float,
        default=None,
        help="end an episode when its summed reward falls below this, as the seed's -250 cut on LunarLander "
        "(default: no floor)",
    )
    parser.add_argument(
        "--max-steps",
        type=int,
        default=None,
        help="stop a seed at its first update after this many training steps, its finished episodes kept (default: no cap)",
    )
    parser.add_argument(
        "--max-episode-steps",
        type=int,
        default=1_000_000,
        help="stop a seed whose episode runs this many steps without ending: the rollout buffer holds whole "
        "episodes, and an env without a time limit can run forever (default: %(default)s)",
    )
    parser.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="parallel seeds, >= 1 (default: the CPU cores, %(default)s)"
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder (required)")
    return parser


def main(argv: list[str] | None = None) -> None:
    """Command line entry point (see the module docstring)."""
    # The compare extra's modules, imported before anything is written
    from sb3_reinforce.lab.cluster import Job, JobResult, open_client, run_jobs, sigterm_as_interrupt
    from sb3_reinforce.lab.seed.summary import render_seed

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.episodes < 1:
        parser.error("--seeds and --episodes must be >= 1")
    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    if args.max_steps is not None and args.max_steps < 1:
        parser.error(f"--max-steps must be >= 1, got {args.max_steps}")
    if args.max_episode_steps < 1:
        parser.error(f"--max-episode-steps must be >= 1, got {args.max_episode_steps}")
    try:
        check_env_id(args.env)
    except ValueError as error:
        parser.error(str(error))
    args.out.mkdir(parents=True, exist_ok=True)
    todo = [
        s
        for s in range(args.seeds)
        if not _finished(args.out / f"episodes_seed{s}.csv", args.episodes, args.max_steps, args.max_episode_steps)
    ]
    settings = (args.episodes, args.reward_floor, args.max_steps, args.max_episode_steps)
    jobs = [Job(f"seed{s}", _run_seed_on_worker, (args.env, s, *settings), 1, f"episodes_seed{s}.*") for s in todo]

    def write(files: dict[str, bytes]) -> None:
        for name, data in files.items():
            (args.out / Path(name).name).write_bytes(data)

    def on_result(name: str, result: JobResult) -> None:
        (args.out / f"episodes_{name}.stopped").unlink(missing_ok=True)  # a seed that stopped early before
        write(result.files)

    try:
        # `kill PID` stops the command as Ctrl-C does
        with sigterm_as_interrupt(), open_client(None, max(1, min(args.workers, len(jobs))), 1) as client:
            failures = run_jobs(client, jobs, lambda name, steps, files: write(files), on_result)
    except KeyboardInterrupt:
        print(
            f"Interrupted: the finished episodes are kept in {args.out}; run the same command to finish "
            "(a seed that was not finished starts over)."
        )
        sys.exit(130)
    for name, reason in failures.items():
        print(f"{name} failed: {reason}")
    if failures:
        sys.exit(1)

    print(render_seed(args.out))
    print(f"{len(todo)} seed(s) trained, {args.seeds - len(todo)} already done: {args.out}")


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
