"""
``sb3-reinforce compare``: REINFORCE vs PPO vs A2C (or any rl_zoo3 algorithm) on one env, same seeds and evaluation.

    sb3-reinforce compare --env CartPole-v1 --seeds 3

Runs go on Dask (a local cluster, or ``--scheduler``'s) into ``OUT/per_run/``; a rerun skips finished runs, so it
resumes or extends a comparison. The tables and plot are rebuilt from all finished runs at the end.
"""

import argparse
import os
import sys
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from sb3_reinforce.lab.cluster import (
    ClusterError,
    Job,
    JobResult,
    RunChannel,
    check_workers,
    open_client,
    run_jobs,
    sigterm_as_interrupt,
)
from sb3_reinforce.lab.compare.experiment import (
    DEFAULT_ALGOS,
    VEC_ENV_TYPES,
    ZooEntry,
    check_where,
    known_algos,
    read_entry,
    run_cpus,
)
from sb3_reinforce.lab.compare.figures import plot_learning_curves, summary_table, to_markdown
from sb3_reinforce.lab.compare.folder import ComparisonFolder, RunSpec
from sb3_reinforce.lab.compare.runner import run
from sb3_reinforce.lab.extras import import_gym_packages
from sb3_reinforce.lab.stats import solve_threshold

__all__ = ["build_parser", "main", "parse_specs", "runs_to_do", "write_outputs"]

#: Evaluations per run when --eval-freq is not given.
DEFAULT_EVALS_PER_RUN = 20
#: The largest seed: NumPy seeds are < 2**32 and a run also uses ``seed + EVAL_SEED_OFFSET`` and ``seed + n_envs - 1``.
MAX_SEED = 2**31 - 1


def build_parser() -> argparse.ArgumentParser:
    """The ``compare`` command's argument parser."""
    parser = argparse.ArgumentParser(
        prog="sb3-reinforce compare",
        description="Train REINFORCE, PPO and A2C on the same env with the same seeds and evaluation protocol.",
    )
    _add_run_arguments(parser.add_argument_group("the runs and their evaluation"))
    _add_config_arguments(parser.add_argument_group("the algorithms' hyperparameters"))
    _add_execution_arguments(parser.add_argument_group("where and how they run"))
    return parser


def _add_run_arguments(parser: argparse._ArgumentGroup) -> None:
    """The arguments that define the comparison's runs: env, algorithms, seeds, budget, evaluation, output."""
    parser.add_argument(
        "--env",
        default="CartPole-v1",
        help="Gymnasium env id: registered, or registered by a --gym-packages module, or as module:EnvName-v0 "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--gym-packages",
        nargs="+",
        default=None,
        metavar="MODULE",
        help="modules to import first, which register your environments (as rl_zoo3's; the current folder is searched "
        "too); an algorithm whose zoo file has no entry for the env trains with its 'default' entry, its defaults "
        "(default: none)",
    )
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
        "--stop-at-threshold",
        action="store_true",
        help="end each run at its first deterministic evaluation at or above the threshold, the untrained policy's "
        "left out (for the training seconds and steps to reach it: the 'final' figures are then those at the stop)",
    )
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: runs/compare/<env>)")


def _add_config_arguments(parser: argparse._ArgumentGroup) -> None:
    """The arguments that name the algorithms' zoo files (their hyperparameters)."""
    parser.add_argument(
        "--config",
        nargs="+",
        default=None,
        metavar="ALGO=FILE",
        help="an algorithm's zoo yml in place of its own (REINFORCE's: the package's zoo_configs/reinforce.yml; "
        "another's: the installed rl_zoo3's), e.g. --config ppo=my_ppo.yml; a file with only a 'default' entry "
        "trains the algorithm on any env with that entry; read only for the algorithms compared (default: none)",
    )
    parser.add_argument(
        "--reinforce-config", type=Path, default=None, help="the same as --config reinforce=FILE (default: none)"
    )


def _add_execution_arguments(parser: argparse._ArgumentGroup) -> None:
    """The arguments of where and how the runs train: workers, environment processes, device, cluster, progress."""
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="parallel runs: the worker processes of the local cluster, >= 1; with --scheduler, the cluster's workers "
        f"decide (default: one per CPU core, {os.cpu_count() or 1} here; with --vec-env subproc, the cores divided by "
        "the largest n_envs, as such a run keeps n_envs cores busy)",
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
    parser.add_argument(
        "--device",
        default="cpu",
        help="where the runs' networks compute: cpu, cuda, cuda:N, mps or auto (SB3's: CUDA where there is one). "
        "Every run of a comparison uses it; on the CPU the runs' timings stay comparable and their results "
        "reproducible bit for bit. Not part of a run's settings: a run may resume on another device "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        help="run on the Dask cluster of this scheduler, tcp://HOST:PORT or tls://HOST:PORT (TLS files from Dask's "
        "configuration, distributed.comm.tls); each worker lends its threads as CPUs, or N with --resources CPU=N "
        "(default: a local cluster on 127.0.0.1 of --workers processes, started and closed by the command)",
    )
    parser.add_argument("--dashboard", action="store_true", help="serve the local cluster's Dask dashboard on 127.0.0.1:8787")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def _parse_threshold(text: str | None, env_id: str) -> float | None:
    if text is None:
        return solve_threshold(env_id)
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--threshold must be a number, got {text!r}") from None


def _check_numbers(args: argparse.Namespace) -> None:
    """Check the counts of the command line: seeds, first seed, workers, evaluation episodes."""
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    if not 0 <= args.first_seed <= MAX_SEED - args.seeds + 1:
        raise ValueError(
            f"--first-seed must be from 0 to {MAX_SEED - args.seeds + 1:,} (the seeds run from 0 to {MAX_SEED:,}), "
            f"got {args.first_seed}"
        )
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    if args.eval_episodes < 1:
        raise ValueError(f"--eval-episodes must be >= 1, got {args.eval_episodes}")


def _algos(text: str) -> list[str]:
    """The algorithms of ``--algos``, in order, each once; refuse one rl_zoo3 does not know."""
    algos = list(dict.fromkeys(algo.strip().lower() for algo in text.split(",") if algo.strip()))
    known = known_algos()
    unknown = [algo for algo in algos if algo not in known]
    if unknown or not algos:
        raise ValueError(f"Unknown algorithm(s) {unknown or text!r}: choose among {', '.join(known)}")
    return algos


def _configs(items: list[str], reinforce_config: Path | None, algos: list[str]) -> dict[str, Path | None]:
    """Each compared algorithm's zoo yml from ``--config ALGO=FILE ...`` and ``--reinforce-config`` (None: its own)."""
    given: dict[str, Path] = {}
    known = known_algos()
    for item in items:
        algo, _, path = item.partition("=")
        algo = algo.strip().lower()
        if not path or algo not in known:
            raise ValueError(f"--config takes ALGO=FILE with ALGO among {', '.join(known)}, got {item!r}")
        if algo in given:
            raise ValueError(f"--config names {algo} twice: give each algorithm one file")
        given[algo] = Path(path)
    if reinforce_config is not None:
        if "reinforce" in given:
            raise ValueError("--reinforce-config and --config reinforce=FILE are the same option: give one")
        given["reinforce"] = reinforce_config
    return {algo: given.get(algo) for algo in algos}


def _budgets(text: str, env_id: str, entries: dict[str, ZooEntry]) -> dict[str, int]:
    """Each algorithm's budget from ``--budget``: PPO's zoo budget, each its own, or a number of steps."""
    if text in ("ppo", "zoo"):
        ppo_budget = 0
        if text == "ppo":  # PPO's budget (its entry's n_timesteps, whatever the kind of training environments)
            ppo_budget = (entries["ppo"] if "ppo" in entries else read_entry("ppo", env_id)).n_timesteps
        return {algo: ppo_budget or entry.n_timesteps for algo, entry in entries.items()}
    try:
        budget = int(float(text))
    except ValueError:
        raise ValueError(f"--budget must be 'ppo', 'zoo' or a number of steps, got {text!r}") from None
    if budget < 1:
        raise ValueError(f"--budget must be >= 1 step, got {budget}")
    return dict.fromkeys(entries, budget)


def _env_module(args: argparse.Namespace) -> None:
    """``--env module:EnvName-v0`` (Gymnasium's form) as ``--env EnvName-v0 --gym-packages module``."""
    if ":" in args.env:
        module, args.env = args.env.split(":", 1)
        args.gym_packages = [*(args.gym_packages or []), module]


def parse_specs(args: argparse.Namespace) -> tuple[list[RunSpec], float | None, dict[str, ZooEntry]]:
    """
    Check the arguments and read every algorithm's zoo entry (once), before anything is trained.

    :param args: The parsed command line
    :return: The runs (finished or not, each with its entry), the solve threshold and each algorithm's zoo entry
    :raises ValueError: on any bad input, with a message saying what to change
    """
    _env_module(args)
    import_gym_packages(args.gym_packages or [])
    check_where(args.env, args.vec_env, args.device, here=args.scheduler is None)
    algos = _algos(args.algos)
    _check_numbers(args)
    threshold = _parse_threshold(args.threshold, args.env)
    if args.stop_at_threshold and threshold is None:
        raise ValueError(f"--stop-at-threshold needs a threshold: {args.env} has no known one, give --threshold")
    stop_at = threshold if args.stop_at_threshold else None
    configs = _configs(args.config or [], args.reinforce_config, algos)
    entries = {algo: read_entry(algo, args.env, config, args.vec_env) for algo, config in configs.items()}
    budgets = _budgets(args.budget, args.env, entries)
    if args.eval_freq is not None and args.eval_freq < 1:
        raise ValueError(f"--eval-freq must be >= 1, got {args.eval_freq}")
    eval_freqs = {algo: args.eval_freq or max(1, budgets[algo] // DEFAULT_EVALS_PER_RUN) for algo in algos}
    config_names = {algo: None if path is None else str(path) for algo, path in configs.items()}
    # Seed-major order: a stopped command's finished runs compare all algorithms on the same seeds
    specs = [
        RunSpec(
            args.env,
            algo,
            seed,
            budgets[algo],
            eval_freqs[algo],
            args.eval_episodes,
            config_names[algo],
            stop_at,
            entries[algo],
        )
        for seed in range(args.first_seed, args.first_seed + args.seeds)
        for algo in algos
    ]
    return specs, threshold, entries


def runs_to_do(specs: list[RunSpec], out_dir: Path) -> list[RunSpec]:
    """The runs still to do; refuse an output folder whose finished runs used other settings."""
    return ComparisonFolder(out_dir).runs_to_do(specs)


def config_of(spec: RunSpec) -> Path | None:
    """A run's zoo yml (None: its algorithm's default)."""
    return None if spec.config_path is None else Path(spec.config_path)


def _train(
    channel: RunChannel, spec: RunSpec, vec_env: str, device: str = "cpu", gym_packages: tuple[str, ...] = ()
) -> dict[str, Any]:
    """On a worker: train ``spec`` in the run's folder there, sending its files back after each evaluation."""
    import_gym_packages(gym_packages)  # the worker's process registers the user's envs too
    return run(spec, channel.folder, progress=channel.send, vec_env=vec_env, heartbeat=channel.check_stop, device=device)


def _run_all(todo: list[RunSpec], folder: ComparisonFolder, args: argparse.Namespace) -> dict[str, str]:
    """
    Run ``todo`` on Dask, writing each run's files into ``folder`` as they come back.

    :return: The runs that failed: name -> reason
    """
    specs = {spec.name: spec for spec in todo}
    jobs = [
        Job(
            spec.name,
            _train,
            (spec, args.vec_env, args.device, tuple(args.gym_packages or [])),
            run_cpus((spec.entry or read_entry(spec.algo, spec.env_id, config_of(spec), args.vec_env)).n_envs, args.vec_env),
            folder.run_files_pattern(spec),
            folder.run_files(spec),
        )
        for spec in todo
    ]
    budgets = {spec.name: spec.budget for spec in todo}
    done_steps: dict[str, int] = {}
    most_cpus = max(job.cpus for job in jobs)
    workers = max(1, (os.cpu_count() or 1) // most_cpus) if args.workers is None else args.workers
    n_workers = min(workers, len(todo))
    dashboard = "127.0.0.1:8787" if args.dashboard else None
    with (
        open_client(args.scheduler, n_workers, most_cpus, dashboard) as client,
        tqdm(total=sum(budgets.values()), unit="step", disable=args.no_progress, desc="compare") as bar,
    ):
        if args.scheduler is not None:
            check_workers(client, most_cpus, args.scheduler)
        if dashboard is not None:
            bar.write(f"Dask dashboard: {client.dashboard_link}")

        def advance(name: str, steps: int) -> None:
            steps = min(steps, budgets[name])  # a run may end a little past its budget
            bar.update(max(0, steps - done_steps.get(name, 0)))
            done_steps[name] = max(steps, done_steps.get(name, 0))

        def on_files(name: str, steps: int, files: dict[str, bytes]) -> None:
            folder.write_run_files(files)
            advance(name, steps)

        def on_result(name: str, result: JobResult) -> None:
            folder.write_finished_run(specs[name], result.files, result.worker)
            advance(name, budgets[name])
            finished.add(name)
            bar.set_postfix(finished=f"{len(finished)}/{len(todo)}")

        finished: set[str] = set()
        return run_jobs(client, jobs, on_files, on_result)


def write_outputs(out_dir: Path, env_id: str, threshold: float | None) -> pd.DataFrame | None:
    """
    Rebuild ``results.csv``, ``summary.csv``, ``summary.md`` and ``learning_curve.png`` from the finished runs.

    :param out_dir: The comparison's output folder
    :param env_id: The environment (for the plot's title)
    :param threshold: The solve threshold
    :return: The summary table, or None if no run has finished
    """
    folder = ComparisonFolder(out_dir)
    results = folder.finished_evaluations()
    if results is None:
        return None
    order = {algo: i for i, algo in enumerate([*DEFAULT_ALGOS, *sorted(set(results["algo"]) - set(DEFAULT_ALGOS))])}
    results = results.sort_values(["algo", "seed", "eval_index"], key=lambda c: c.map(order) if c.name == "algo" else c)
    results.to_csv(folder.output(folder.RESULTS), index=False)
    table = summary_table(results, folder.load_summaries(), threshold)
    table.to_csv(folder.output(folder.SUMMARY_CSV), index=False)
    folder.output(folder.SUMMARY_MD).write_text(to_markdown(table))
    plot_learning_curves(results, threshold, folder.output(folder.LEARNING_CURVE), f"{env_id}: deterministic evaluation")
    return table


def _announce(specs: list[RunSpec], todo: list[RunSpec], folder: ComparisonFolder) -> None:
    """Print what the command will do: the runs, finished or not, and each algorithm's budget, evaluation and entry."""
    resuming = sum(folder.checkpoint(spec, {}).exists() for spec in todo)
    print(
        f"{len(specs)} runs of {specs[0].env_id} -> {folder.root}: {len(specs) - len(todo)} already finished, "
        f"{resuming} resume from a checkpoint, {len(todo) - resuming} start from scratch"
    )
    for algo in dict.fromkeys(spec.algo for spec in specs):
        spec = next(s for s in specs if s.algo == algo)
        stop = "" if spec.stop_at is None else f", ending at the first deterministic evaluation >= {spec.stop_at:g}"
        evaluation = f"evaluation every {spec.eval_freq:,} steps x {spec.n_eval_episodes} episodes"
        print(f"  {algo}: {spec.budget:,} steps, {evaluation}{stop}")
        entry = spec.entry
        if entry is not None and entry.fallback is not None:
            print(
                f"    {entry.source.name} has no entry for {spec.env_id}: its {entry.fallback!r} entry is used "
                f"({entry.hyperparams.get('policy')}, {entry.n_envs} env(s)), not tuned for this environment"
            )


def main(argv: list[str] | None = None) -> None:
    """Command line entry point (see the module docstring)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _env_module(args)
    folder = ComparisonFolder(args.out or Path("runs") / "compare" / args.env)
    try:
        specs, threshold, _ = parse_specs(args)
        todo = folder.runs_to_do(specs)
    except ValueError as error:  # one line (the usage would hide it): what to change
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        sys.exit(2)
    folder.write_meta(args.env, threshold)
    _announce(specs, todo, folder)
    interrupted = False
    failures: dict[str, str] = {}
    try:
        with sigterm_as_interrupt():  # `kill PID` stops the command as Ctrl-C does
            if todo:
                failures = _run_all(todo, folder, args)
    except KeyboardInterrupt:
        interrupted = True
    except ClusterError as error:
        print(f"sb3-reinforce compare: error: {error}", file=sys.stderr)
        sys.exit(2)
    if write_outputs(folder.root, args.env, threshold) is not None:
        results = pd.read_csv(folder.output(folder.RESULTS))
        print(summary_table(results, folder.load_summaries(), threshold, compact=True).to_string(index=False))
        saved = (folder.output(name) for name in (folder.RESULTS, folder.SUMMARY_MD, folder.LEARNING_CURVE))
        print(f"Saved {', '.join(map(str, saved))}")
    if interrupted:
        print(f"Interrupted: the finished runs are kept in {folder.runs_dir}; run the same command to resume.")
        sys.exit(130)
    for name, reason in failures.items():
        print(f"Run {name} failed: {reason}; run the same command to try it again from its last checkpoint.")
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
