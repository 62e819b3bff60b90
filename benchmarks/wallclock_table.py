"""
Issue 64's wall-clock table: the training seconds each zoo entry needs to reach its env's threshold, from the
comparison folders of ``results/wallclock/run.sh`` (``REPEAT/ENV/``, runs stopped at their first deterministic
evaluation at or above the threshold, ``--stop-at-threshold``).

Per run (a row of ``results/wallclock/runs.csv``): the steps and training seconds (evaluations excluded) at the first
evaluation past step 0 at or above the threshold (``inf``: not reached within the budget), and the machine's 1-minute
load average at the run's start and end. The table (``results/wallclock/table.md``) gives per env and algorithm the
median over seeds of each repeat, and REINFORCE's median against PPO's.

    python benchmarks/wallclock_table.py
"""

import argparse
import math
from pathlib import Path

import pandas as pd

from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.stats import first_crossing, quantile_with_inf

RESULTS = Path(__file__).parent / "results" / "wallclock"


def runs(root: Path) -> pd.DataFrame:
    """One row per finished run of every ``root/REPEAT/ENV`` comparison folder."""
    rows = []
    for folder_path in sorted(path.parent for path in root.glob(f"*/*/{ComparisonFolder.META}")):
        folder = ComparisonFolder(folder_path)
        env_id, threshold = folder.read_meta()
        evaluations = folder.finished_evaluations()
        if evaluations is None or threshold is None:
            continue
        for (algo, seed), summary in sorted(folder.load_summaries().items()):
            run = evaluations[(evaluations["algo"] == algo) & (evaluations["seed"] == seed)].sort_values("eval_index")
            trained = run[run["eval_index"] > 0]
            load_start, load_end = summary.get("load_1min", [math.nan, math.nan])
            rows.append(
                dict(
                    repeat=folder_path.parent.name,
                    env_id=env_id,
                    threshold=threshold,
                    algo=algo,
                    seed=seed,
                    steps_to_threshold=first_crossing(trained["steps"], trained["mean_return"], threshold),
                    seconds_to_threshold=first_crossing(trained["wall_time_s"], trained["mean_return"], threshold),
                    steps=summary["steps"],
                    train_time_s=summary["train_time_s"],
                    load_1min_start=load_start,
                    load_1min_end=load_end,
                )
            )
    return pd.DataFrame(rows)


def table(per_run: pd.DataFrame) -> str:
    """Markdown: per env and algorithm, each repeat's median seconds to the threshold; REINFORCE's against PPO's."""
    lines = ["| env (threshold) | algorithm | seeds | median training s to reach, per repeat | load (1 min) | vs PPO |"]
    lines.append("|---|---|---|---|---|---|")
    for (env_id, threshold), env_runs in per_run.groupby(["env_id", "threshold"], sort=False):
        medians: dict[str, dict[str, float]] = {}
        for algo in sorted(env_runs["algo"].unique(), key=lambda name: (name != "ppo", name)):  # PPO first: the ratio's
            algo_runs = env_runs[env_runs["algo"] == algo]
            per_repeat = {
                repeat: quantile_with_inf(list(runs_["seconds_to_threshold"]), 0.5)
                for repeat, runs_ in algo_runs.groupby("repeat")
            }
            medians[algo] = per_repeat
            shown = ", ".join("not reached" if math.isinf(v) else f"{v:,.1f}" for v in per_repeat.values())
            seeds = f"{algo_runs['seed'].nunique()} ({algo_runs['seed'].min()}-{algo_runs['seed'].max()})"
            load = f"{algo_runs['load_1min_start'].min():.2f}-{algo_runs['load_1min_start'].max():.2f}"
            ratio = ""
            if algo != "ppo" and "ppo" in medians:
                pairs = [(v, medians["ppo"][r]) for r, v in per_repeat.items() if r in medians["ppo"]]
                ratio = ", ".join(f"{v / ppo:.2f}x" if math.isfinite(v) and math.isfinite(ppo) else "-" for v, ppo in pairs)
            lines.append(f"| {env_id} ({threshold:g}) | {algo.upper()} | {seeds} | {shown} | {load} | {ratio} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    per_run = runs(args.root)
    if per_run.empty:
        raise SystemExit(f"no finished runs under {args.root}")
    per_run.to_csv(args.root / "runs.csv", index=False)
    markdown = table(per_run)
    (args.root / "table.md").write_text(markdown)
    print(markdown)


if __name__ == "__main__":
    main()
