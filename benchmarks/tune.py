"""
An Optuna study of REINFORCE that cannot pick a spike.

Every trial trains at the full budget on several seeds with ``sb3-reinforce compare``'s runner (the same
evaluation protocol: deterministic then sampled-action episodes every ``--eval-freq`` steps, one CSV row
each), and is scored on the **mean of the last ``--score-last`` deterministic evaluations of each seed,
averaged over the seeds** (by default the last quarter of training). No single evaluation decides a trial.
The tuning seeds (``--seeds``) must be kept apart from the seeds a result is reported on.

Workers: run the same command in as many shells as there are cores; they share the study through its
storage (a journal file ``STUDY_DIR/study.log`` by default, or ``--storage postgresql://...``). A stopped
study resumes with the same command: finished trials are kept, ``--max-trials`` counts them.

    python benchmarks/tune.py --env LunarLander-v3 --base-config benchmarks/configs/reinforce_lunarlander_lin.yml \\
        --study-dir benchmarks/results/study_lunarlander --seeds 100 101 --max-trials 30 \\
        --fixed benchmarks/results/study_lunarlander/fixed.yml --enqueue benchmarks/results/study_lunarlander/enqueue.yml

Outputs in ``--study-dir``: ``trials/NNN/config.yml`` (the trial's zoo entry) and ``trials/NNN/per_run/``
(the runner's CSV and JSON per seed), ``trials.csv`` (every trial, rewritten after each one) and
``best_config.yml`` (the best finished trial's zoo entry).
"""

import argparse
import math
import os
import socket
from pathlib import Path
from typing import Any

import numpy as np
import optuna
import pandas as pd
import yaml

from sb3_reinforce.lab.compare.command import runs_to_do
from sb3_reinforce.lab.compare.folder import ComparisonFolder, RunSpec
from sb3_reinforce.lab.compare.runner import run
from sb3_reinforce.lab.zoo.hyperparams_opt import suggest_reinforce_params, zoo_entry
from sb3_reinforce.reinforce.buffers import RolloutLimitError


def score_run(csv_path: Path, last: int) -> float:
    """The mean of the last ``last`` deterministic evaluations of one run."""
    returns = pd.read_csv(csv_path)["mean_return"].to_numpy()
    return float(np.mean(returns[-last:]))


def trial_entry(base: dict[str, Any], params: dict[str, Any], budget: int) -> dict[str, Any]:
    """The base config's entry with the trial's values on top (and the budget)."""
    return {**base, **zoo_entry(params), "n_timesteps": budget}


def build_objective(args: argparse.Namespace, base: dict[str, Any]) -> Any:
    def objective(trial: optuna.Trial) -> float:
        trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
        # Observation normalization is searched unless the base config sets the zoo's `normalize` for every trial
        params = suggest_reinforce_params(trial, search_normalization="normalize" not in base)
        # A rerun of an interrupted trial goes on in its folder: finished seeds are kept, a checkpointed one resumes
        folder_number = trial.user_attrs.get("rerun_of", trial.number)
        trial_dir = args.study_dir / "trials" / f"{folder_number:03d}"
        trial_dir.mkdir(parents=True, exist_ok=True)
        config_path = trial_dir / "config.yml"
        entry = trial_entry(base, params, args.budget)
        config_path.write_text(yaml.safe_dump({args.env: entry}, sort_keys=True))
        scores = []
        for index, seed in enumerate(args.seeds):
            spec = RunSpec(args.env, "reinforce", seed, args.budget, args.eval_freq, args.eval_episodes, str(config_path))
            try:
                if runs_to_do([spec], trial_dir):  # not finished yet
                    run(spec, trial_dir)
            except (FloatingPointError, RolloutLimitError) as error:  # a non-finite update, an endless episode
                raise optuna.TrialPruned(f"seed {seed}: {error}") from error
            scores.append(score_run(ComparisonFolder(trial_dir).evaluations_path(spec), args.score_last))
            trial.set_user_attr("seed_scores", scores)
            trial.report(float(np.mean(scores)), index)
            if index < len(args.seeds) - 1 and trial.should_prune():
                raise optuna.TrialPruned(f"after seed {seed}: {np.mean(scores):.1f}")
        return float(np.mean(scores))

    return objective


def export(study: optuna.Study, args: argparse.Namespace, base: dict[str, Any]) -> None:
    """Write ``trials.csv`` and, once a trial has finished, ``best_config.yml``."""
    study.trials_dataframe().to_csv(args.study_dir / "trials.csv", index=False)
    finished = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    if finished:
        best = max(finished, key=lambda t: t.value if t.value is not None else -math.inf)
        entry = trial_entry(base, best.params, args.budget)
        header = (
            f"# Trial {best.number} of study {study.study_name} ({len(finished)} finished trials): score {best.value:.1f}, "
            f"the mean over seeds {args.seeds} of the last {args.score_last} deterministic evaluations.\n"
        )
        (args.study_dir / "best_config.yml").write_text(header + yaml.safe_dump({args.env: entry}, sort_keys=True))


def rerun_interrupted(study: optuna.Study) -> None:
    """Mark the study's RUNNING trials (their workers were stopped) failed, and queue their parameters again."""
    for trial in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
        study._storage.set_trial_state_values(trial._trial_id, state=optuna.trial.TrialState.FAIL)
        first = trial.user_attrs.get("rerun_of", trial.number)  # a rerun's rerun goes on in the first one's folder
        study.enqueue_trial(dict(trial.params), user_attrs={"rerun_of": first})
        print(f"Trial {trial.number} was interrupted: queued again")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", required=True)
    parser.add_argument("--base-config", type=Path, required=True, help="zoo yml whose entry for --env the trials start from")
    parser.add_argument("--study-dir", type=Path, required=True)
    parser.add_argument("--study-name", default=None, help="default: reinforce-<env>")
    parser.add_argument("--storage", default=None, help="Optuna storage URL (default: a journal file STUDY_DIR/study.log)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[100, 101], help="tuning seeds (at least 2)")
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the base config's n_timesteps)")
    parser.add_argument("--eval-freq", type=int, default=None, help="default: budget / 20")
    parser.add_argument("--eval-episodes", type=int, default=5)
    parser.add_argument("--score-last", type=int, default=5, help="evaluations averaged per seed (default: 5)")
    parser.add_argument("--max-trials", type=int, default=30, help="finished trials (complete or pruned) in the study")
    parser.add_argument("--fixed", type=Path, default=None, help="yml of search parameters held fixed (PartialFixedSampler)")
    parser.add_argument(
        "--enqueue",
        type=Path,
        nargs="+",
        default=[],
        help="yml lists of parameter sets tried before the sampler's (each file once per study, in order)",
    )
    parser.add_argument("--sampler-seed", type=int, default=None)
    parser.add_argument(
        "--rerun-interrupted",
        action="store_true",
        help="first mark the study's RUNNING trials failed and queue them again (resuming a stopped study: only when "
        "no other worker is running; a journal file has no heartbeats to tell a dead worker's trial from a live one)",
    )
    args = parser.parse_args(argv)
    if len(args.seeds) < 2:
        parser.error("--seeds: a trial needs at least 2 seeds")
    base = dict(yaml.load(args.base_config.read_text(), Loader=yaml.UnsafeLoader)[args.env])
    args.budget = args.budget or int(float(base["n_timesteps"]))
    args.eval_freq = args.eval_freq or max(1, args.budget // 20)
    args.study_dir.mkdir(parents=True, exist_ok=True)
    storage: Any = args.storage or optuna.storages.JournalStorage(
        optuna.storages.journal.JournalFileBackend(str(args.study_dir / "study.log"))
    )
    sampler: optuna.samplers.BaseSampler = optuna.samplers.TPESampler(n_startup_trials=5, seed=args.sampler_seed)
    if args.fixed is not None:
        sampler = optuna.samplers.PartialFixedSampler(yaml.safe_load(args.fixed.read_text()), sampler)
    study = optuna.create_study(
        study_name=args.study_name or f"reinforce-{args.env}",
        storage=storage,
        sampler=sampler,
        pruner=optuna.pruners.MedianPruner(n_startup_trials=4),
        direction="maximize",
        load_if_exists=True,
    )
    # Studies from before several files were allowed recorded only that their one file (enqueue.yml) was queued
    enqueued_files = study.user_attrs.get("enqueued_files", ["enqueue.yml"] if study.user_attrs.get("enqueued") else [])
    for path in args.enqueue:
        if path.name not in enqueued_files:
            for params in yaml.safe_load(path.read_text()):
                study.enqueue_trial(params, skip_if_exists=True)
            enqueued_files = [*enqueued_files, path.name]
            study.set_user_attr("enqueued_files", enqueued_files)
    if args.rerun_interrupted:
        rerun_interrupted(study)
    states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    if len(study.get_trials(deepcopy=False, states=states)) >= args.max_trials:
        print(f"The study has its {args.max_trials} finished trials: nothing to do")
        export(study, args, base)
        return
    study.optimize(
        build_objective(args, base),
        callbacks=[
            optuna.study.MaxTrialsCallback(args.max_trials, states=states),
            lambda study, trial: export(study, args, base),
        ],
    )
    export(study, args, base)


if __name__ == "__main__":
    main()
