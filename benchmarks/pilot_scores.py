"""
Per-run scores of comparison folders, as the pilots' READMEs and docs/results.md quote them: for each run, the
first evaluation at or above the threshold (counted after training started, as ``sb3-reinforce report``) and the
training seconds to it (its ``wall_time_s``: evaluations excluded), the mean of the last 5 evaluations (the
pilots' tuning score), the final evaluation (deterministic and sampled actions), the best one, how many
evaluations from ``--from-steps`` on are at or above the threshold, and with ``--mean-at`` the mean of the
deterministic evaluations at those steps (CarRacing's target reads 900k, 950k and 1M).

    python benchmarks/pilot_scores.py benchmarks/results/mountaincar_pilot/* --threshold -110
    python benchmarks/pilot_scores.py benchmarks/results/verify_acrobot --threshold -100
    python benchmarks/pilot_scores.py benchmarks/results/verify_carracing --threshold 500 --mean-at 900000 950000 1000000

A folder without ``results.csv`` (a study trial's) is read from its ``per_run/*.csv``. Files among the arguments (a
study folder's README.md, run script and log, which ``STUDY/*`` names too) are skipped. ``LABEL=FOLDER`` pools
folders under one label, so that one config's seeds from a study trial and from a later run are scored together:

    python benchmarks/pilot_scores.py t7=benchmarks/results/study_lunarlander_1m/trials/007 \
        t7=benchmarks/results/lunarlander_rescore/t7_value20_clip --threshold 200
"""

import argparse
import math
from pathlib import Path

import pandas as pd

from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.stats import first_crossing


def read_results(folder: Path) -> pd.DataFrame:
    """A comparison folder's evaluations: its ``results.csv``, or else its ``per_run/*.csv`` (a study trial's)."""
    if (folder / "results.csv").is_file():
        return pd.read_csv(folder / "results.csv")
    per_run = sorted(ComparisonFolder(folder).runs_dir.glob("*.csv"))  # a trial's: finished or not
    if not per_run:
        raise FileNotFoundError(f"{folder} has neither results.csv nor per_run/*.csv")
    return pd.concat([pd.read_csv(path) for path in per_run], ignore_index=True)


def evaluations_at(run: pd.DataFrame, steps: tuple[int, ...]) -> list[float]:
    """
    A run's deterministic evaluations at exactly these steps (the periodic ones, not the final evaluation after the
    last rollout), NaN for a step the run has not reached.
    """
    at = run.set_index("steps")["mean_return"]
    return [float(at[step]) if step in at.index else math.nan for step in steps]


def run_scores(
    folder: Path, threshold: float, from_steps: int, label: str | None = None, mean_at: tuple[int, ...] = ()
) -> pd.DataFrame:
    """
    One row per (algorithm, seed) of a comparison folder; ``label`` names it (default: the folder's name). With
    ``mean_at``, a column holds the mean of :func:`evaluations_at` those steps, NaN while one of them is missing.
    """
    rows = []
    for (algo, seed), run in read_results(folder).groupby(["algo", "seed"], sort=False):
        run = run.sort_values("eval_index")
        trained = run[run["eval_index"] > 0]
        first = first_crossing(trained["steps"], trained["mean_return"], threshold)
        seconds = trained.loc[trained["steps"] == first, "wall_time_s"]
        late = run[run["steps"] >= from_steps]
        rows.append(
            {
                "folder": label or folder.name,
                "algo": algo,
                "seed": seed,
                "steps": int(run["steps"].iloc[-1]),
                "first >= threshold": int(first) if first < float("inf") else "never",
                "training s to it": round(float(seconds.iloc[0]), 1) if len(seconds) else math.nan,
                "last 5": round(run["mean_return"].iloc[-5:].mean(), 1),
                "final": round(run["mean_return"].iloc[-1], 1),
                "final sampled": round(run["mean_return_stochastic"].iloc[-1], 1),
                "best": round(run["mean_return"].max(), 1),
                f"evals from {from_steps:,} >= threshold": f"{(late['mean_return'] >= threshold).sum()}/{len(late)}",
            }
        )
        if mean_at:
            values = evaluations_at(run, mean_at)
            rows[-1]["mean at " + ", ".join(f"{steps:,}" for steps in mean_at)] = round(sum(values) / len(values), 1)
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("folders", nargs="+", help="comparison folders (results.csv or per_run/*.csv), PATH or LABEL=PATH")
    parser.add_argument("--threshold", type=float, required=True, help="the env's solve threshold")
    parser.add_argument("--from-steps", type=int, default=800_000, help="count late evaluations from here (default: 800,000)")
    parser.add_argument(
        "--mean-at",
        type=int,
        nargs="+",
        default=[],
        metavar="STEPS",
        help="also the mean of the deterministic evaluations at these steps (e.g. 900000 950000 1000000)",
    )
    args = parser.parse_args(argv)
    labelled = [arg.split("=", 1) if "=" in arg else [None, arg] for arg in args.folders]
    labelled = [(label, path) for label, path in labelled if not Path(path).is_file()]
    table = pd.concat(
        [run_scores(Path(path), args.threshold, args.from_steps, label, tuple(args.mean_at)) for label, path in labelled]
    )
    with pd.option_context("display.width", 250, "display.max_columns", None, "display.max_rows", None):
        print(table.to_string(index=False))
        grouped = table.groupby(["folder", "algo"], sort=False)
        per_folder = grouped["last 5"].agg(["mean", "count"]).round(1)
        per_folder["median training s to first"] = grouped["training s to it"].median().round(1)
        print(
            "\nmean of the runs' last-5 scores (count: seeds), median training seconds to the first crossing:\n"
            + per_folder.to_string()
        )


if __name__ == "__main__":
    main()
