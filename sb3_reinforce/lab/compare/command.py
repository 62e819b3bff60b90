"""
``sb3-reinforce compare``: REINFORCE vs PPO vs A2C (or any rl_zoo3 algorithm) on one env, same seeds and evaluation.

    sb3-reinforce compare --env CartPole-v1 --seeds 3

Runs go on Dask (a local cluster, or ``--scheduler``'s) into ``OUT/per_run/``; a rerun skips finished runs, so it
resumes or extends a comparison. The tables and plot are rebuilt from all finished runs at the end.
"""

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from sb3_reinforce.lab.compare.cluster import (
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
    check_device,
    check_vec_env,
    known_algos,
    read_entry,
    run_cpus,
)
from sb3_reinforce.lab.compare.figures import PER_RUN_DIR, load_summaries, plot_learning_curves, summary_table, to_markdown
from sb3_reinforce.lab.compare.runner import Checkpoint, RunSpec, run, write_replacing
from sb3_reinforce.lab.extras import check_env_id
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
        "--workers",
        type=int,
        default=None,
        help="parallel runs: the worker processes of the local cluster, >= 1; with --scheduler, the cluster's workers "
        f"decide (default: one per CPU core, {os.cpu_count() or 1} here; with --vec-env subproc, the cores divided by "
        "the largest n_envs, as such a run keeps n_envs cores busy)",
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
    return parser


def _parse_threshold(text: str | None, env_id: str) -> float | None:
    if text is None:
        return solve_threshold(env_id)
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--threshold must be a number, got {text!r}") from None


def parse_specs(args: argparse.Namespace) -> tuple[list[RunSpec], float | None, dict[str, ZooEntry]]:
    """
    Check the arguments and load every algorithm's hyperparameters, before anything is trained.

    :param args: The parsed command line
    :return: The runs (finished or not), the solve threshold and each algorithm's zoo entry
    :raises ValueError: on any bad input, with a message saying what to change
    """
    check_env_id(args.env)
    check_vec_env(args.vec_env, args.env)
    check_device(args.device, here=args.scheduler is None)
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
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    if args.eval_episodes < 1:
        raise ValueError(f"--eval-episodes must be >= 1, got {args.eval_episodes}")
    threshold = _parse_threshold(args.threshold, args.env)
    config_paths = {algo: None for algo in algos}
    if args.reinforce_config is not None:
        config_paths["reinforce"] = args.reinforce_config
    entries = {algo: read_entry(algo, args.env, config_paths[algo], args.vec_env) for algo in algos}
    if args.budget in ("ppo", "zoo"):
        ppo_budget = read_entry("ppo", args.env).n_timesteps if args.budget == "ppo" else 0
        budgets = {algo: ppo_budget or entries[algo].n_timesteps for algo in algos}
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
    # Seed-major order: a stopped command's finished runs compare all algorithms on the same seeds
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
    return specs, threshold, entries


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


def _train(channel: RunChannel, spec: RunSpec, vec_env: str, device: str = "cpu") -> dict[str, Any]:
    """On a worker: train ``spec`` in the run's folder there, sending its files back after each evaluation."""
    return run(spec, channel.folder, progress=channel.send, vec_env=vec_env, heartbeat=channel.check_stop, device=device)


def _write_files(out_dir: Path, files: dict[str, bytes]) -> None:
    """Write a run's files (relative paths) into ``out_dir`` atomically; JSON files (completion marks) go last."""
    for relative in files:
        if Path(relative).is_absolute() or ".." in Path(relative).parts:
            raise ValueError(f"a run sent back a file outside its folder: {relative!r}")
        if relative.endswith(".json"):
            (out_dir / relative).unlink(missing_ok=True)
    for relative, data in sorted(files.items(), key=lambda item: item[0].endswith(".json")):
        (out_dir / relative).parent.mkdir(parents=True, exist_ok=True)
        write_replacing(out_dir / relative, data)


def _run_files(out_dir: Path, spec: RunSpec) -> dict[str, bytes]:
    """The files of an unfinished run in ``out_dir`` (its CSV and checkpoint), to resume it wherever it lands."""
    runs_dir = out_dir / PER_RUN_DIR
    return {
        path.relative_to(out_dir).as_posix(): path.read_bytes()
        for path in sorted(runs_dir.glob(f"{spec.name}.*"))
        if ".tmp" not in path.name
    }


def _run_all(todo: list[RunSpec], out_dir: Path, args: argparse.Namespace) -> dict[str, str]:
    """
    Run ``todo`` on Dask, writing each run's files into ``out_dir`` as they come back.

    :return: The runs that failed: name -> reason
    """
    n_envs = {(s.algo, s.config_path): 0 for s in todo}
    for algo, config in n_envs:
        config_path = None if config is None else Path(config)
        n_envs[algo, config] = read_entry(algo, todo[0].env_id, config_path, args.vec_env).n_envs
    jobs = [
        Job(
            spec.name,
            _train,
            (spec, args.vec_env, args.device),
            run_cpus(n_envs[spec.algo, spec.config_path], args.vec_env),
            f"{PER_RUN_DIR}/{spec.name}.*",
            _run_files(out_dir, spec),
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
            _write_files(out_dir, files)
            advance(name, steps)

        def on_result(name: str, result: JobResult) -> None:
            summary_name = f"{PER_RUN_DIR}/{name}.json"
            summary = dict(json.loads(result.files[summary_name]), worker=result.worker)
            _write_files(out_dir, result.files | {summary_name: json.dumps(summary, indent=2).encode()})
            for path in (out_dir / PER_RUN_DIR).glob(f"{name}.*"):  # its checkpoint, deleted at its end
                if path.relative_to(out_dir).as_posix() not in result.files:
                    path.unlink()
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
        specs, threshold, entries = parse_specs(args)
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
        if entries[algo].fallback is not None:
            print(
                f"    {entries[algo].source.name} has no entry for {args.env}: rl_zoo3's {entries[algo].fallback!r} "
                f"entry is used ({entries[algo].hyperparams.get('policy')}, {entries[algo].n_envs} env(s)), "
                "not tuned for this environment"
            )
    interrupted = False
    failures: dict[str, str] = {}
    try:
        with sigterm_as_interrupt():  # `kill PID` stops the command as Ctrl-C does
            if todo:
                failures = _run_all(todo, out_dir, args)
    except KeyboardInterrupt:
        interrupted = True
    except ClusterError as error:
        print(f"sb3-reinforce compare: error: {error}", file=sys.stderr)
        sys.exit(2)
    if write_outputs(out_dir, args.env, threshold) is not None:
        compact = summary_table(pd.read_csv(out_dir / "results.csv"), load_summaries(out_dir), threshold, compact=True)
        print(compact.to_string(index=False))
        print(f"Saved {out_dir / 'results.csv'}, {out_dir / 'summary.md'}, {out_dir / 'learning_curve.png'}")
    if interrupted:
        print(f"Interrupted: the finished runs are kept in {out_dir / PER_RUN_DIR}; run the same command to resume.")
        sys.exit(130)
    for name, reason in failures.items():
        print(f"Run {name} failed: {reason}; run the same command to try it again from its last checkpoint.")
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
