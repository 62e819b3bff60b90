"""
A verification target, seed by seed: for each run of a comparison folder, (a) the first deterministic evaluation at
or above the threshold and (b) the mean of the deterministic evaluations over the last fraction of the budget, met
when at or above the threshold (and beside it the same mean of the sampled-action evaluations, which the target
does not read); with the run's best and final evaluations. Per algorithm: on how many seeds both hold, and the
final IQM over its finished seeds with its 95% bootstrap CI (as ``compare``'s summary computes it).
CarRacing-v3's target at 4M steps (issue 63) reads the evaluations at 3.6M-4.0M:

    python benchmarks/seed_targets.py benchmarks/results/verify_carracing_4m --budget 4000000

The runs are read from ``per_run/*.csv``, so a run under way has a row (its steps so far, "under way" for what it
has not reached). ``--into PAGE`` writes the table into a markdown page between ``<!-- seed_targets FOLDER -->``
markers (FOLDER: the folder's name), which the page must already hold.
"""

import argparse
import math
from pathlib import Path

import pandas as pd

from sb3_reinforce.lab.compare.figures import to_markdown
from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.report import require_markers, write_between_markers
from sb3_reinforce.lab.stats import bootstrap_ci, first_crossing, iqm

UNDER_WAY = "under way"
#: The per-seed table's columns, in order (:func:`seed_rows`).
COLUMNS = (
    "algorithm",
    "seed",
    "steps",
    "(a) first evaluation >= threshold",
    "(b) mean of the last evaluations",
    "the same, sampled actions",
    "target",
    "best",
    "final",
    "final, sampled actions",
)


def marker(folder: Path) -> str:
    """The marker pair's name that ``--into`` writes a folder's table between."""
    return f"seed_targets {folder.name}"


def read_runs(folder: Path) -> pd.DataFrame:
    """
    Every evaluation of every run in ``folder/per_run/``, finished or not: REINFORCE's runs first, then by algorithm,
    seed and evaluation.
    """
    paths = sorted(ComparisonFolder(folder).runs_dir.glob("*.csv"))
    if not paths:
        raise FileNotFoundError(f"{folder} has no per_run/*.csv")
    runs = pd.concat([pd.read_csv(path) for path in paths], ignore_index=True)
    runs["others_first"] = runs["algo"] != "reinforce"
    runs = runs.sort_values(["others_first", "algo", "seed", "eval_index"], ignore_index=True)
    return runs.drop(columns="others_first")


def seed_rows(runs: pd.DataFrame, threshold: float, budget: int, last_fraction: float) -> pd.DataFrame:
    """
    One row per (algorithm, seed): (a), (b) and whether the target holds, with the best and final evaluations.

    :param runs: Evaluations as :func:`read_runs` returns them
    :param threshold: The score both parts of the target are read against
    :param budget: The runs' training steps; a run is finished once an evaluation reaches it
    :param last_fraction: (b) averages the periodic evaluations at steps in ``[(1 - last_fraction) * budget, budget]``
    """
    if not 0.0 < last_fraction <= 1.0:
        raise ValueError(f"last_fraction must be in (0, 1], got {last_fraction}")
    window_start = (1.0 - last_fraction) * budget
    rows = []
    for (algo, seed), run in runs.groupby(["algo", "seed"], sort=False):
        trained = run[run["eval_index"] > 0]
        first = first_crossing(trained["steps"], trained["mean_return"], threshold)
        row = dict.fromkeys(COLUMNS, UNDER_WAY)  # what a run under way has not reached
        row |= {
            "algorithm": str(algo).upper(),
            "seed": int(seed),
            "steps": f"{int(run['steps'].iloc[-1]):,}",
            "best": round(float(run["mean_return"].max()), 1),
        }
        if first < math.inf:
            row["(a) first evaluation >= threshold"] = f"{int(first):,}"
        if run["steps"].iloc[-1] >= budget:  # finished
            late = run[(run["steps"] >= window_start) & (run["steps"] <= budget)]
            late_mean = float(late["mean_return"].mean())
            row |= {
                "(b) mean of the last evaluations": f"{late_mean:.1f}",
                "the same, sampled actions": f"{late['mean_return_stochastic'].mean():.1f}",
                "target": "met" if first < math.inf and late_mean >= threshold else "missed",
                "final": round(float(run["mean_return"].iloc[-1]), 1),
                "final, sampled actions": round(float(run["mean_return_stochastic"].iloc[-1]), 1),
            }
            if first == math.inf:
                row["(a) first evaluation >= threshold"] = "never"
        rows.append(row)
    return pd.DataFrame(rows)


def algorithm_lines(rows: pd.DataFrame) -> list[str]:
    """Per algorithm: the seeds that meet the target, and the final IQM [95% CI] of its finished seeds."""
    lines = []
    for algo, table in rows.groupby("algorithm", sort=False):
        finished = table[table["target"] != UNDER_WAY]
        line = f"- {algo}: the target met on {(table['target'] == 'met').sum()} of {len(table)} seeds"
        if len(finished) < len(table):
            line += f" ({len(table) - len(finished)} under way)"
        if len(finished):
            finals = finished["final"].astype(float).to_numpy()
            low, high = bootstrap_ci(finals, iqm)
            line += f"; final IQM over {len(finished)} finished: {iqm(finals):.1f} [{low:.1f}, {high:.1f}]"
        lines.append(line)
    return lines


def render(folder: Path, threshold: float, budget: int, last_fraction: float) -> str:
    """The markdown table and the per-algorithm lines."""
    rows = seed_rows(read_runs(folder), threshold, budget, last_fraction)
    window = f"{(1.0 - last_fraction) * budget:,.0f}-{budget:,}"
    rows = rows.rename(
        columns={
            "(a) first evaluation >= threshold": f"(a) first evaluation >= {threshold:g}",
            "(b) mean of the last evaluations": f"(b) mean of the evaluations at {window}",
        }
    )
    return to_markdown(rows) + "\n" + "\n".join(algorithm_lines(rows)) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("folder", type=Path, help="a comparison folder (its per_run/*.csv are read)")
    parser.add_argument("--budget", type=int, required=True, help="the runs' training steps")
    parser.add_argument("--last-fraction", type=float, default=0.1, help="(b)'s share of the budget (default: 0.1)")
    parser.add_argument("--threshold", type=float, help="default: the folder's comparison.json threshold")
    parser.add_argument("--into", type=Path, action="append", default=[], metavar="PAGE", help="a page to write into")
    args = parser.parse_args(argv)
    threshold = args.threshold
    if threshold is None:
        _, threshold = ComparisonFolder(args.folder).read_meta()
        if threshold is None:
            parser.error(f"{args.folder}/comparison.json names no threshold: pass --threshold")
    require_markers(args.into, marker(args.folder))
    text = render(args.folder, float(threshold), args.budget, args.last_fraction)
    print(text, end="")
    for page in args.into:
        write_between_markers(page, marker(args.folder), text)
        print(f"Wrote {page}")


if __name__ == "__main__":
    main()
