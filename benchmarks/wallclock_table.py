"""
Issue 64's wall-clock table: the training seconds each zoo entry needs to reach its env's threshold, from the
comparison folders of ``results/wallclock/run.sh`` (``REPEAT/ENV/``, runs stopped at their first deterministic
evaluation at or above the threshold, ``--stop-at-threshold``).

Per run (a row of ``ROOT/runs.csv``): the steps and training seconds (evaluations excluded) at the first evaluation
past step 0 at or above the threshold (``inf``: not reached within the budget), and the machine's 1-minute load
average at the run's start and end. ``ROOT/table.md`` gives per env and algorithm the median over seeds of each
repeat, and REINFORCE's median against PPO's.

The page's table (``--into``) has one row per env: REINFORCE's, PPO's and A2C's medians, REINFORCE's against PPO's
per repeat, and whether it is at or below PPO's in both repeats (the benchmark's rule). An env run again with a
changed entry (``--current FOLDER``, a root of the same layout, its PPO and A2C run beside it) takes that folder's
runs of the env instead of ``--root``'s; the first folder naming an env wins.

    python benchmarks/wallclock_table.py
    python benchmarks/wallclock_table.py --current benchmarks/results/wallclock/candidates/e4_loo --into README.md
"""

import argparse
import math
import re
from pathlib import Path

import gymnasium as gym
import pandas as pd

from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.report import require_markers, write_between_markers
from sb3_reinforce.lab.stats import first_crossing, quantile_with_inf

RESULTS = Path(__file__).parent / "results" / "wallclock"
REPOSITORY = Path(__file__).resolve().parents[1]
#: The markers between which ``--into`` writes the page's table
MARKER = "wallclock"
REPEATS = 2


def _shown(path: Path) -> str:
    """A folder as the pages name it: relative to the repository where it lies inside it."""
    resolved = path.resolve()
    return resolved.relative_to(REPOSITORY).as_posix() if resolved.is_relative_to(REPOSITORY) else path.as_posix()


def _cpu(name: str) -> str:
    """A processor's make and family, as SB3's system info names it: "Intel(R) Xeon(R) Processor" -> "Intel Xeon"."""
    return " ".join(re.sub(r"\((R|TM)\)", "", name).split()[:2])


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
                    folder=_shown(root),
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
                    cpu=_cpu(summary.get("system", {}).get("CPU", "")),
                )
            )
    return pd.DataFrame(rows)


def medians(env_runs: pd.DataFrame) -> dict[str, dict[str, float]]:
    """Per algorithm, per repeat: the median over seeds of the training seconds to the threshold (inf: not reached)."""
    return {
        str(algo): {
            str(repeat): quantile_with_inf(list(repeat_runs["seconds_to_threshold"]), 0.5)
            for repeat, repeat_runs in algo_runs.groupby("repeat")
        }
        for algo, algo_runs in env_runs.groupby("algo")
    }


def _seconds(per_repeat: dict[str, float]) -> str:
    """One algorithm's medians, repeat by repeat (inf: not reached)."""
    return ", ".join("not reached" if math.isinf(value) else f"{value:,.1f}" for _, value in sorted(per_repeat.items()))


def _pairs(per_algo: dict[str, dict[str, float]], algo: str) -> list[tuple[float, float]]:
    """``algo``'s median and PPO's, per repeat both ran (inf: not reached)."""
    ppo = per_algo.get("ppo", {})
    return [(seconds, ppo[repeat]) for repeat, seconds in sorted(per_algo.get(algo, {}).items()) if repeat in ppo]


def _ratio(seconds: float, ppo: float) -> str:
    """One repeat's median over PPO's, or which of the two never reached the threshold."""
    if math.isinf(seconds):
        return "neither reached" if math.isinf(ppo) else "not reached"
    return "PPO not reached" if math.isinf(ppo) else f"{seconds / ppo:.2f}x"


def table(per_run: pd.DataFrame) -> str:
    """Markdown: per env and algorithm, each repeat's median seconds to the threshold; REINFORCE's against PPO's."""
    lines = ["| env (threshold) | algorithm | seeds | median training s to reach, per repeat | load (1 min) | vs PPO |"]
    lines.append("|---|---|---|---|---|---|")
    for (env_id, threshold), env_runs in per_run.groupby(["env_id", "threshold"], sort=False):
        per_algo = medians(env_runs)
        for algo in sorted(per_algo, key=lambda name: (name != "ppo", name)):  # PPO first: the ratios are to it
            algo_runs = env_runs[env_runs["algo"] == algo]
            shown = _seconds(per_algo[algo])
            seeds = f"{algo_runs['seed'].nunique()} ({algo_runs['seed'].min()}-{algo_runs['seed'].max()})"
            load = f"{algo_runs['load_1min_start'].min():.2f}-{algo_runs['load_1min_start'].max():.2f}"
            ratio = "" if algo == "ppo" else ", ".join(_ratio(*pair) for pair in _pairs(per_algo, algo))
            lines.append(f"| {env_id} ({threshold:g}) | {algo.upper()} | {seeds} | {shown} | {load} | {ratio} |")
    return "\n".join(lines) + "\n"


def current_runs(root_runs: pd.DataFrame, candidates: list[pd.DataFrame]) -> pd.DataFrame:
    """Every env's runs from the first of ``candidates`` (then ``root_runs``) that holds the env."""
    chosen: list[pd.DataFrame] = []
    seen: set[str] = set()
    for source in [*candidates, root_runs]:
        if source.empty:
            continue
        fresh = source[~source["env_id"].isin(seen)]
        seen.update(fresh["env_id"])
        chosen.append(fresh)
    return pd.concat(chosen, ignore_index=True)


def _is_mujoco(env_id: str) -> bool:
    return str(gym.spec(env_id).entry_point).startswith("gymnasium.envs.mujoco")


def _algo_cell(env_runs: pd.DataFrame, per_algo: dict[str, dict[str, float]], algo: str) -> str:
    if algo not in per_algo:
        return "-"
    cell = _seconds(per_algo[algo])
    algo_runs = env_runs[env_runs["algo"] == algo]
    reached = int(algo_runs["seconds_to_threshold"].map(math.isfinite).sum())
    return cell if reached == len(algo_runs) else f"{cell} ({reached} of {len(algo_runs)} runs reach)"


def page_table(per_run: pd.DataFrame) -> str:
    """
    Markdown for the pages: one row per env (the classic tasks, then MuJoCo's, each alphabetical), the medians over
    seeds of each repeat, REINFORCE's against PPO's and the rule's verdict: at or below PPO's in both repeats.
    """
    lines = [
        "| env (threshold) | REINFORCE | PPO | A2C | REINFORCE / PPO | at or below PPO | load (1 min) | CPU "
        "| REINFORCE's entry |",
        "|---|---:|---:|---:|---|---|---|---|---|",
    ]
    envs = per_run[["env_id", "threshold"]].drop_duplicates().itertuples(index=False)
    for env_id, threshold in sorted(envs, key=lambda env: (_is_mujoco(env[0]), env[0])):
        env_runs = per_run[per_run["env_id"] == env_id]
        per_algo = medians(env_runs)
        pairs = _pairs(per_algo, "reinforce")
        if len(pairs) < REPEATS:
            verdict = f"{len(pairs)} of {REPEATS} repeats run"
        else:  # the rule: at or below PPO's median in every repeat (not reached: infinitely late, so inf <= inf)
            verdict = "yes" if all(seconds <= ppo for seconds, ppo in pairs) else "**no**"
        cells = [_algo_cell(env_runs, per_algo, algo) for algo in ("reinforce", "ppo", "a2c")]
        load = f"{env_runs['load_1min_start'].min():.2f}-{env_runs['load_1min_start'].max():.2f}"
        cpus = ", ".join(sorted(set(env_runs["cpu"])))
        folder = env_runs.loc[env_runs["algo"] == "reinforce", "folder"].iloc[0]
        ratio = ", ".join(_ratio(*pair) for pair in pairs)
        lines.append(
            f"| {env_id} ({threshold:g}) | {' | '.join(cells)} | {ratio} | {verdict} | {load} | {cpus} | `{folder}` |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", type=Path, default=RESULTS)
    replaces = "a root of the same layout whose envs' runs replace --root's on the page (repeatable)"
    parser.add_argument("--current", type=Path, action="append", default=[], metavar="FOLDER", help=replaces)
    into = f"a markdown page to write the table into, between <!-- {MARKER} --> markers (repeatable)"
    parser.add_argument("--into", type=Path, action="append", default=[], metavar="PAGE", help=into)
    args = parser.parse_args(argv)
    require_markers(args.into, MARKER)
    per_run = runs(args.root)
    if per_run.empty:
        raise SystemExit(f"no finished runs under {args.root}")
    per_run.to_csv(args.root / "runs.csv", index=False)
    (args.root / "table.md").write_text(table(per_run))
    page = page_table(current_runs(per_run, [runs(folder) for folder in args.current]))
    for path in args.into:
        write_between_markers(path, MARKER, page)
    print(page)


if __name__ == "__main__":
    main()
