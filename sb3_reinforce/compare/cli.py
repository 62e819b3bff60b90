"""
``sb3-reinforce compare``: REINFORCE vs PPO vs A2C (or any algorithm rl_zoo3 knows) on one environment, same seeds,
same evaluation protocol. Every run is built by rl_zoo3's experiment manager from the algorithm's zoo entry, as
``sb3-reinforce-zoo train`` builds it (see :mod:`sb3_reinforce.compare.experiment`).

    sb3-reinforce compare --env CartPole-v1 --seeds 3

Every argument is checked, and every algorithm's hyperparameters are loaded, before any training starts.
Runs go in parallel processes (one per CPU core by default), each writing its own files under
``OUT/per_run/``; finished runs are skipped when the command is run again, so a comparison can be resumed
after an interruption or extended with more seeds or algorithms. ``OUT/results.csv``, ``OUT/summary.md``
and ``OUT/learning_curve.png`` are rebuilt from all the finished runs at the end.
"""

import argparse
import contextlib
import json
import multiprocessing as mp
import os
import queue
import signal
import sys
from collections.abc import Callable, Iterator
from multiprocessing.managers import SyncManager
from multiprocessing.pool import Pool
from pathlib import Path
from typing import Any, TypeVar

import gymnasium as gym
import pandas as pd
from tqdm import tqdm

from sb3_reinforce.compare.experiment import DEFAULT_ALGOS, VEC_ENV_TYPES, check_vec_env, known_algos, read_entry
from sb3_reinforce.compare.report import PER_RUN_DIR, load_summaries, plot_learning_curves, summary_table, to_markdown
from sb3_reinforce.compare.runner import Checkpoint, RunSpec, run
from sb3_reinforce.lab.stats import solve_threshold

__all__ = [
    "build_parser",
    "ignore_sigint",
    "main",
    "parse_specs",
    "run_stoppable",
    "sigterm_as_keyboard_interrupt",
    "worker_pool",
    "write_outputs",
]

#: Evaluations per run when --eval-freq is not given.
DEFAULT_EVALS_PER_RUN = 20
#: The largest seed a run may have: NumPy seeds must be < 2**32, and a run also seeds its evaluation environment
#: ``seed + EVAL_SEED_OFFSET`` and its training environments ``seed .. seed + n_envs - 1``.
MAX_SEED = 2**31 - 1


def build_parser() -> argparse.ArgumentParser:
    """The ``compare`` command's argument parser."""
    parser = argparse.ArgumentParser(
        prog="sb3-reinforce compare",
        description="Train REINFORCE, PPO and A2C on the same env with the same seeds and evaluation protocol.",
    )
    parser.add_argument("--env", default="CartPole-v1", help="Gymnasium env id (default: %(default)s)")
    parser.add_argument(
        "--algos",
        default=",".join(DEFAULT_ALGOS),
        help="comma-separated rl_zoo3 algorithms, REINFORCE included, e.g. also trpo (default: %(default)s)",
    )
    parser.add_argument("--seeds", type=int, default=3, help="number of seeds, >= 1 (default: %(default)s)")
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help=f"seeds are first-seed, first-seed+1, ..., from 0 to {MAX_SEED:,} (default: %(default)s)",
    )
    parser.add_argument(
        "--budget",
        default="ppo",
        help="training steps of every run: 'ppo' (PPO's zoo budget for the env, for every algorithm), "
        "'zoo' (each algorithm its own zoo budget), or a number of steps (default: %(default)s)",
    )
    parser.add_argument(
        "--eval-freq", type=int, default=None, help=f"evaluate every N env steps (default: budget / {DEFAULT_EVALS_PER_RUN})"
    )
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=5,
        help="episodes per evaluation, deterministic and again stochastic (default: %(default)s)",
    )
    parser.add_argument("--threshold", default=None, help="solve threshold (default: the env's known one, if any)")
    parser.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="parallel runs, >= 1 (default: the CPU cores, %(default)s)"
    )
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: runs/compare/<env>)")
    parser.add_argument(
        "--reinforce-config",
        type=Path,
        default=None,
        help="REINFORCE's zoo yml (default: the package's zoo_configs/reinforce.yml)",
    )
    parser.add_argument(
        "--vec-env",
        choices=VEC_ENV_TYPES,
        default="dummy",
        help="training environments of a run stepped in its own process (dummy), one process each (subproc: a run "
        "then keeps n_envs cores busy, for environments slow to step such as CarRacing-v3), or EnvPool's C++ threads "
        "(envpool: the envpool extra, the Box2D and classic-control tasks; evaluation stays on Gymnasium's env); not "
        "part of a run's settings, so a run may resume with another (default: %(default)s)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def _parse_threshold(text: str | None, env_id: str) -> float | None:
    if text is None:
        return solve_threshold(env_id)
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--threshold must be a number, got {text!r}") from None


def parse_specs(args: argparse.Namespace) -> tuple[list[RunSpec], float | None]:
    """
    Check the arguments and load every algorithm's hyperparameters, before anything is trained.

    :param args: The parsed command line
    :return: The runs (finished or not) and the solve threshold
    :raises ValueError: on any bad input, with a message saying what to change
    """
    try:
        gym.spec(args.env)
    except gym.error.Error as error:
        raise ValueError(f"Unknown environment {args.env!r}: {error}") from None
    check_vec_env(args.vec_env, args.env)
    algos = list(dict.fromkeys(algo.strip().lower() for algo in args.algos.split(",") if algo.strip()))
    known = known_algos()
    unknown = [algo for algo in algos if algo not in known]
    if unknown or not algos:
        raise ValueError(f"Unknown algorithm(s) {unknown or args.algos!r}: choose among {', '.join(known)}")
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    if not 0 <= args.first_seed <= MAX_SEED - args.seeds + 1:
        raise ValueError(
            f"--first-seed must be from 0 to {MAX_SEED - args.seeds + 1:,} (the seeds run from 0 to {MAX_SEED:,}), "
            f"got {args.first_seed}"
        )
    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    if args.eval_episodes < 1:
        raise ValueError(f"--eval-episodes must be >= 1, got {args.eval_episodes}")
    threshold = _parse_threshold(args.threshold, args.env)
    config_paths = {algo: None for algo in algos}
    if args.reinforce_config is not None:
        config_paths["reinforce"] = args.reinforce_config
    configs = {algo: read_entry(algo, args.env, config_paths[algo], args.vec_env) for algo in algos}
    if args.budget in ("ppo", "zoo"):
        ppo_budget = read_entry("ppo", args.env).n_timesteps if args.budget == "ppo" else 0
        budgets = {algo: ppo_budget or configs[algo].n_timesteps for algo in algos}
    else:
        try:
            budget = int(float(args.budget))
        except ValueError:
            raise ValueError(f"--budget must be 'ppo', 'zoo' or a number of steps, got {args.budget!r}") from None
        if budget < 1:
            raise ValueError(f"--budget must be >= 1 step, got {budget}")
        budgets = dict.fromkeys(algos, budget)
    if args.eval_freq is not None and args.eval_freq < 1:
        raise ValueError(f"--eval-freq must be >= 1, got {args.eval_freq}")
    eval_freqs = {algo: args.eval_freq or max(1, budgets[algo] // DEFAULT_EVALS_PER_RUN) for algo in algos}
    # Seed-major order: whenever the command is stopped, the finished runs compare all algorithms on the same seeds.
    specs = [
        RunSpec(
            args.env,
            algo,
            seed,
            budgets[algo],
            eval_freqs[algo],
            args.eval_episodes,
            None if config_paths[algo] is None else str(config_paths[algo]),
        )
        for seed in range(args.first_seed, args.first_seed + args.seeds)
        for algo in algos
    ]
    return specs, threshold


def runs_to_do(specs: list[RunSpec], out_dir: Path) -> list[RunSpec]:
    """The runs still to do; refuse an output folder whose finished runs used other settings."""
    todo = []
    for spec in specs:
        path = out_dir / PER_RUN_DIR / f"{spec.name}.json"
        if not path.exists():
            todo.append(spec)
            continue
        done = json.loads(path.read_text())["spec"]
        if done != spec.__dict__:
            raise ValueError(f"{path} is a finished run with other settings ({done}): use another --out, or the same settings")
    return todo


@contextlib.contextmanager
def sigterm_as_keyboard_interrupt() -> Iterator[None]:
    """
    Within the block, SIGTERM (``kill PID``) raises ``KeyboardInterrupt`` in the main process, as Ctrl-C does, so
    that a worker pool is terminated on the way out instead of being left running without its parent.
    """

    def _raise(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def ignore_sigint() -> None:
    """Ignore SIGINT in this process (a worker's initializer: its parent stops it)."""
    # Ctrl-C reaches the whole process group: only the main process handles it (it stops the workers itself).
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def ignore_stop_signals() -> None:
    """Ignore SIGINT and SIGTERM (the message manager's initializer: the main process shuts it down last)."""
    # A SIGTERM sent to the whole process group (`kill -- -PGID`, a container or session being stopped) must not
    # take the manager down before the main process has stopped the workers: the pool's cleanup still talks to it.
    ignore_sigint()
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


_T = TypeVar("_T")


def _start_worker() -> None:
    """
    A pool worker's initializer: ignore the stop signals while waiting (see :func:`worker_pool`), and allow the
    worker to start processes of its own (``--vec-env subproc``'s environments).
    """
    ignore_stop_signals()
    # Pool marks its workers daemonic, and a daemonic process may not have children. Only the worker's own view of
    # the flag is cleared: the main process still sees daemonic workers, so that on its way out it terminates them
    # instead of waiting for their runs to end.
    mp.current_process().daemon = False


def worker_pool(processes: int, maxtasksperchild: int | None = None) -> Pool:
    """
    A pool of ``processes`` spawned workers that ignore SIGINT and SIGTERM while they wait for a task; run each task
    through :func:`run_stoppable`.

    Ctrl-C, and SIGTERM sent to the whole process group (``kill -- -PGID``), reach every worker. A worker killed while
    it waits for a task dies holding the task queue's lock, and ``Pool.terminate`` (on the way out of the pool's
    ``with`` block) then waits for that lock forever; a waiting worker that ignores the signal leaves on the pool's
    own signal instead. Only the main process handles the stop: it terminates the workers itself. A pool that ends
    normally must be closed and joined inside its ``with`` block: ``Pool.terminate`` (the block's exit) holds the task
    queue's lock, so a worker still starting (a replacement under ``maxtasksperchild``, or one that never got a task)
    would wait for that lock forever, ignoring the pool's SIGTERM, and the pool would wait for it.

    A worker may start processes of its own (``--vec-env subproc``'s environments): when it is stopped, SB3's
    ``SubprocVecEnv`` environment processes leave at their next wait for a command, which finds their pipe closed.

    :param processes: Number of workers
    :param maxtasksperchild: Tasks a worker runs before a fresh one replaces it (``None``: no limit)
    :return: The pool, to use as a context manager
    """
    return mp.get_context("spawn").Pool(processes, initializer=_start_worker, maxtasksperchild=maxtasksperchild)


def run_stoppable(fn: Callable[..., _T], *args: Any) -> _T:
    """
    Run ``fn(*args)`` in a worker of :func:`worker_pool` with SIGTERM at its default, so that ``Pool.terminate``
    (SIGTERM) or a SIGTERM to the process group stops the task; the worker ignores SIGTERM again once it returns.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        return fn(*args)
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)


def _worker(spec: RunSpec, out_dir: Path, messages: Any, vec_env: str) -> dict[str, Any]:
    return run(spec, out_dir, progress=lambda steps: messages.put((spec.name, steps)), vec_env=vec_env)


def _run_all(todo: list[RunSpec], out_dir: Path, workers: int, show_progress: bool, vec_env: str = "dummy") -> None:
    manager = SyncManager(ctx=mp.get_context("spawn"))
    manager.start(ignore_stop_signals)
    n_workers = max(1, min(workers, len(todo)))
    with manager, worker_pool(n_workers, maxtasksperchild=1) as pool:
        messages = manager.Queue()
        pending = [pool.apply_async(run_stoppable, (_worker, spec, out_dir, messages, vec_env)) for spec in todo]
        done_steps: dict[str, int] = {}
        with tqdm(total=sum(s.budget for s in todo), unit="step", disable=not show_progress, desc="compare") as bar:
            while pending:
                try:
                    name, steps = messages.get(timeout=0.5)
                    budget = next(s.budget for s in todo if s.name == name)
                    steps = min(steps, budget)  # a run may end a little past its budget
                    bar.update(max(0, steps - done_steps.get(name, 0)))
                    done_steps[name] = max(steps, done_steps.get(name, 0))
                except queue.Empty:
                    pass
                for result in [r for r in pending if r.ready()]:
                    pending.remove(result)
                    result.get()  # re-raises a run's error here
                    bar.set_postfix(finished=f"{len(todo) - len(pending)}/{len(todo)}")
        # Ended normally: the waiting workers leave on the pool's sentinels (see worker_pool)
        pool.close()
        pool.join()


def write_outputs(out_dir: Path, env_id: str, threshold: float | None) -> pd.DataFrame | None:
    """
    Rebuild ``results.csv``, ``summary.csv``, ``summary.md`` and ``learning_curve.png`` from the finished
    runs in ``out_dir / PER_RUN_DIR``.

    :param out_dir: The comparison's output folder
    :param env_id: The environment (for the plot's title)
    :param threshold: The solve threshold
    :return: The summary table, or None if no run has finished
    """
    summaries = load_summaries(out_dir)
    if not summaries:
        return None
    frames = [pd.read_csv(out_dir / PER_RUN_DIR / f"{algo}_seed{seed}.csv") for algo, seed in summaries]
    results = pd.concat(frames, ignore_index=True)
    order = {algo: i for i, algo in enumerate([*DEFAULT_ALGOS, *sorted(set(results["algo"]) - set(DEFAULT_ALGOS))])}
    results = results.sort_values(["algo", "seed", "eval_index"], key=lambda c: c.map(order) if c.name == "algo" else c)
    results.to_csv(out_dir / "results.csv", index=False)
    table = summary_table(results, summaries, threshold)
    table.to_csv(out_dir / "summary.csv", index=False)
    (out_dir / "summary.md").write_text(to_markdown(table))
    plot_learning_curves(results, threshold, out_dir / "learning_curve.png", f"{env_id}: deterministic evaluation")
    return table


def main(argv: list[str] | None = None) -> None:
    """Command line entry point (see the module docstring)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    out_dir: Path = args.out or Path("runs") / "compare" / args.env
    try:
        specs, threshold = parse_specs(args)
        todo = runs_to_do(specs, out_dir)
    except ValueError as error:  # one line (the usage would hide it): what to change
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        sys.exit(2)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "comparison.json").write_text(json.dumps(dict(env=args.env, threshold=threshold), indent=2))
    resuming = sum(Checkpoint(out_dir / PER_RUN_DIR, spec, {}).exists() for spec in todo)
    print(
        f"{len(specs)} runs of {args.env} -> {out_dir}: {len(specs) - len(todo)} already finished, "
        f"{resuming} resume from a checkpoint, {len(todo) - resuming} start from scratch"
    )
    for algo in dict.fromkeys(spec.algo for spec in specs):
        spec = next(s for s in specs if s.algo == algo)
        print(f"  {algo}: {spec.budget:,} steps, evaluation every {spec.eval_freq:,} steps x {spec.n_eval_episodes} episodes")
    interrupted = False
    try:
        if todo:
            with sigterm_as_keyboard_interrupt():
                _run_all(todo, out_dir, args.workers, show_progress=not args.no_progress, vec_env=args.vec_env)
    except KeyboardInterrupt:
        interrupted = True
    if write_outputs(out_dir, args.env, threshold) is not None:
        # the terminal's table: summary.md's figures without the IQRs, to fit about 110 columns
        compact = summary_table(pd.read_csv(out_dir / "results.csv"), load_summaries(out_dir), threshold, compact=True)
        print(compact.to_string(index=False))
        print(f"Saved {out_dir / 'results.csv'}, {out_dir / 'summary.md'}, {out_dir / 'learning_curve.png'}")
    if interrupted:
        print(f"Interrupted: the finished runs are kept in {out_dir / PER_RUN_DIR}; run the same command to resume.")
        sys.exit(130)


if __name__ == "__main__":
    main()
