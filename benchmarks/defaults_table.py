"""
Issue 62's defaults table and decision: REINFORCE's candidate defaults against PPO's and A2C's, by the rule that
``results/defaults_study/README.md`` fixed before the runs.

Reads the comparison folders of ``results/defaults_study/run.sh`` (``CANDIDATE/ENV/``), each run's *final*
deterministic evaluation (its last row: 10 episodes after the budget's last whole episode), and writes
``results/defaults_study/runs.csv`` (one row per finished run) and ``table.md``: per task, each candidate's mean final
score over its seeds and whether it solves the task (the mean at or above the threshold), the counts the rule compares,
and the rule's outcome, or which runs it still waits for. Thresholds: Gymnasium's ``reward_threshold`` (Pendulum-v1:
the lab's -200, :func:`~sb3_reinforce.lab.stats.solve_threshold`), MuJoCo: Tianshou's REINFORCE at 3M steps
(``mujoco_thresholds.py --source "Tianshou REINFORCE"``). The suite and its seeds are read off ``queue.sh``.

With ``--verification`` it tabulates the runs on fresh seeds (``verify_queue.sh``, into ``verify/``) the same way and
reports, instead of the rule's outcome, the counts the README's rule 4 reports for the pick, PPO's defaults and today's;
``--pick`` prints rule 2's pick (``verify_queue.sh`` reads it) or fails while the candidates' unfinished runs could
still change it.

``--into PAGE`` writes the same table into a markdown page between ``<!-- defaults -->`` markers (with
``--verification``: ``<!-- defaults_verification -->``), as the results page shows it.

    python benchmarks/defaults_table.py --into docs/results.md
    python benchmarks/defaults_table.py --verification --into docs/results.md
"""

import argparse
import re
import sys
from pathlib import Path

import mujoco_thresholds
import pandas as pd

from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.report import require_markers, write_between_markers
from sb3_reinforce.lab.stats import solve_threshold

HERE = Path(__file__).parent
RESULTS = HERE / "results" / "defaults_study"
#: The rule's candidates for REINFORCE's new defaults (step 2), and what the pick must beat or match (step 3).
CANDIDATES = ("value20", "value20_2048")
TODAY, PPO, A2C = "today", "ppo", "a2c"
#: Every column of the table, in order; A2C is reported, not in the rule.
COLUMNS = (TODAY, *CANDIDATES, PPO, A2C)
MUJOCO_SOURCE = "Tianshou REINFORCE"
#: The columns of runs.csv.
RUN_COLUMNS = ("candidate", "env_id", "seed", "threshold", "steps", "final", "final_sampled", "reached", "train_time_s")
#: The markers between which ``--into`` writes the tuning runs' table, and the fresh seeds' (``--verification``).
MARKER, VERIFICATION_MARKER = "defaults", "defaults_verification"


def _bash_array(text: str, name: str) -> list[str]:
    match = re.search(rf"^{name}=\(([^)]*)\)", text, re.MULTILINE)
    if match is None:
        raise ValueError(f"queue.sh has no {name}=(...) array")
    return match.group(1).split()


def suite(queue: Path = RESULTS / "queue.sh") -> dict[str, list[int]]:
    """The study's tasks and the seeds the rule reads on each, as ``queue.sh`` schedules them."""
    text = queue.read_text()
    seeds = re.search(r"^for seed in ([\d ]+); do", text, re.MULTILINE)
    if seeds is None:
        raise ValueError("queue.sh has no 'for seed in ...' loop over the classic tasks")
    classic_seeds = [int(seed) for seed in seeds.group(1).split()]
    mujoco_seed = re.search(r"FIRST_SEED=(\d+) SEEDS=1 bash \"\$here/run.sh\" \"\$candidate\" \"\$\{mujoco", text)
    if mujoco_seed is None:
        raise ValueError("queue.sh runs no MuJoCo seed per candidate")
    tasks = {env_id: classic_seeds for env_id in _bash_array(text, "classic")}
    return tasks | {env_id: [int(mujoco_seed.group(1))] for env_id in _bash_array(text, "mujoco")}


def thresholds(env_ids: list[str]) -> dict[str, float]:
    """The rule's threshold of each task."""
    published = mujoco_thresholds.thresholds(source=MUJOCO_SOURCE)
    found = {env_id: published[env_id] if env_id in published.index else solve_threshold(env_id) for env_id in env_ids}
    missing = [env_id for env_id, value in found.items() if value is None]
    if missing:
        raise ValueError(f"no threshold for {', '.join(missing)}")
    return {env_id: float(value) for env_id, value in found.items()}


def runs(root: Path, tasks: dict[str, list[int]]) -> pd.DataFrame:
    """One row per finished run of the study's tasks and seeds: its final deterministic and sampled-action scores."""
    limits = thresholds(list(tasks))
    rows = []
    for column in COLUMNS:
        for env_id, seeds in tasks.items():
            folder = ComparisonFolder(root / column / env_id)
            if not folder.holds_comparison(folder.root):
                continue
            evaluations = folder.finished_evaluations()
            for (algo, seed), summary in sorted(folder.load_summaries().items()):
                if seed not in seeds:
                    continue
                assert evaluations is not None
                run = evaluations[(evaluations["algo"] == algo) & (evaluations["seed"] == seed)]
                final = run.loc[run["eval_index"].idxmax()]
                rows.append(
                    dict(
                        candidate=column,
                        env_id=env_id,
                        seed=seed,
                        threshold=limits[env_id],
                        steps=summary["steps"],
                        final=final["mean_return"],
                        final_sampled=final["mean_return_stochastic"],
                        reached=final["mean_return"] >= limits[env_id],
                        train_time_s=summary["train_time_s"],
                    )
                )
    return pd.DataFrame(rows, columns=list(RUN_COLUMNS))


def counts(per_run: pd.DataFrame, tasks: dict[str, list[int]], column: str) -> tuple[int, int, int, int]:
    """
    A column's tasks solved (mean final over the task's seeds at or above its threshold), among the tasks whose runs
    have all finished, the runs at or above the threshold, and how many of its runs are finished and expected.
    """
    mine = per_run[per_run["candidate"] == column]
    solved = complete = 0
    for env_id, seeds in tasks.items():
        task_runs = mine[mine["env_id"] == env_id]
        if set(task_runs["seed"]) >= set(seeds):
            complete += 1
            solved += bool(task_runs["final"].mean() >= task_runs["threshold"].iloc[0])
    return solved, int(mine["reached"].sum()), len(mine), sum(len(seeds) for seeds in tasks.values())


def _unfinished(per_run: pd.DataFrame, tasks: dict[str, list[int]], columns: tuple[str, ...]) -> list[str]:
    """Each of ``columns`` with runs still to finish, as "`column` finished of expected runs"."""
    waiting = []
    for column in columns:
        _, _, finished, expected = counts(per_run, tasks, column)
        if finished < expected:
            waiting.append(f"`{column}` {finished} of {expected} runs")
    return waiting


def bounds(per_run: pd.DataFrame, tasks: dict[str, list[int]], column: str) -> tuple[tuple[int, int], tuple[int, int]]:
    """
    The lowest and highest (tasks solved, runs at or above the threshold) that a column can end with: its finished
    runs as they are, each unfinished task solved or not, each unfinished run at or above the threshold or not.
    """
    solved, reached, finished, expected = counts(per_run, tasks, column)
    mine = per_run[per_run["candidate"] == column]
    open_tasks = sum(not set(mine[mine["env_id"] == env_id]["seed"]) >= set(seeds) for env_id, seeds in tasks.items())
    return (solved, reached), (solved + open_tasks, reached + expected - finished)


def pick(per_run: pd.DataFrame, tasks: dict[str, list[int]]) -> str | None:
    """
    Step 2's pick: the candidate that solves the most tasks, then has the most runs at or above the threshold, then
    ``value20`` (the smaller change); None while the candidates' unfinished runs could still change it (the pick is
    known early when its lowest possible counts beat every other candidate's highest).
    """
    ranges = {column: bounds(per_run, tasks, column) for column in CANDIDATES}
    for column in CANDIDATES:
        lowest = (*ranges[column][0], -CANDIDATES.index(column))
        if all(lowest > (*ranges[other][1], -CANDIDATES.index(other)) for other in CANDIDATES if other != column):
            return column
    return None


def _tasks_solved(low: int, high: int) -> str:
    return str(low) if low == high else f"between {low} and {high}"


def decision(per_run: pd.DataFrame, tasks: dict[str, list[int]]) -> str:
    """
    The rule's outcome (README, "The rule"), or which columns it still waits for; decided before the last runs
    finish when none of their results could change it.
    """
    waiting = _unfinished(per_run, tasks, (TODAY, *CANDIDATES, PPO))
    picked = pick(per_run, tasks)
    if picked is None:
        return "**Not decided yet**: the rule reads every run of its columns; finished so far: " + ", ".join(waiting) + "."
    (pick_low, _), (pick_high, _) = bounds(per_run, tasks, picked)
    (ppo_low, _), (ppo_high, _) = bounds(per_run, tasks, PPO)
    (today_low, _), (today_high, _) = bounds(per_run, tasks, TODAY)
    tasks_pick, tasks_ppo = _tasks_solved(pick_low, pick_high), _tasks_solved(ppo_low, ppo_high)
    others = f"PPO's defaults {tasks_ppo}, today's {_tasks_solved(today_low, today_high)}"
    if pick_low >= ppo_high and pick_low > today_high:
        verdict = f"`{picked}` becomes the constructor's default (step 3: {tasks_pick} tasks solved, {others})"
    elif pick_high < ppo_low or pick_high <= today_low:
        verdict = f"the defaults stay (step 3: `{picked}` solves {tasks_pick} tasks, {others})"
    else:
        return (
            f"**Not decided yet**: step 2's pick is `{picked}` whatever the candidates' unfinished runs give; step 3 "
            f"({tasks_pick} tasks solved, {others}) waits for: " + ", ".join(waiting) + "."
        )
    if waiting:
        return (
            f"**Decided** before its last runs, which cannot change it: the pick is `{picked}` (step 2); {verdict}. "
            "Still running, for the table: " + ", ".join(waiting) + "."
        )
    return f"**Decided**: the pick is `{picked}` (step 2); {verdict}."


def verification_columns(picked: str) -> tuple[str, ...]:
    """The columns that run on fresh seeds (rule 4), in the table's order: today, the pick, PPO."""
    return tuple(column for column in COLUMNS if column in (TODAY, picked, PPO))


def verification(per_run: pd.DataFrame, tasks: dict[str, list[int]], picked: str) -> str:
    """Rule 4's report on fresh seeds: tasks solved and runs at or above the threshold of the pick, PPO and today."""
    columns = (picked, PPO, TODAY)
    if waiting := _unfinished(per_run, tasks, columns):
        return "**Verification under way**: finished so far: " + ", ".join(waiting) + "."
    reported = []
    for column in columns:
        solved, reached, finished, _ = counts(per_run, tasks, column)
        reported.append(f"`{column}` {solved} tasks solved ({reached} of {finished} runs at or above the threshold)")
    return "**On fresh seeds** (rule 4): " + ", ".join(reported) + "."


def table(per_run: pd.DataFrame, tasks: dict[str, list[int]], outcome: str, columns: tuple[str, ...] = COLUMNS) -> str:
    """Markdown: per task each column's mean final score (seeds finished) and whether it solves; counts; ``outcome``."""
    limits = thresholds(list(tasks))
    header = "| task (threshold) | seeds | " + " | ".join(f"`{column}`" for column in columns) + " |"
    lines = [header, "|---|---|" + "---:|" * len(columns)]
    for env_id, seeds in tasks.items():
        cells = []
        for column in columns:
            task_runs = per_run[(per_run["candidate"] == column) & (per_run["env_id"] == env_id)]
            if task_runs.empty:
                cells.append("")
                continue
            mean = task_runs["final"].mean()
            done = len(task_runs) == len(seeds)
            mark = (" **solved**" if mean >= limits[env_id] else "") if done else f" ({len(task_runs)} of {len(seeds)})"
            cells.append(f"{mean:,.1f}{mark}")
        seed_text = ", ".join(map(str, seeds))
        lines.append(f"| {env_id} ({limits[env_id]:g}) | {seed_text} | " + " | ".join(cells) + " |")
    rows = [counts(per_run, tasks, column) for column in columns]
    lines.append("| tasks solved | | " + " | ".join(str(row[0]) for row in rows) + " |")
    lines.append("| runs at or above the threshold | | " + " | ".join(f"{row[1]} of {row[2]}" for row in rows) + " |")
    lines.append("| runs finished | | " + " | ".join(f"{row[2]} of {row[3]}" for row in rows) + " |")
    return "\n".join(lines) + "\n\n" + outcome + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", type=Path, default=RESULTS, help="the study's folder (default: %(default)s)")
    parser.add_argument("--queue", type=Path, default=RESULTS / "queue.sh", help="its schedule (default: %(default)s)")
    parser.add_argument("--verify-root", type=Path, default=RESULTS / "verify", help="default: %(default)s")
    parser.add_argument("--verify-queue", type=Path, default=RESULTS / "verify_queue.sh", help="default: %(default)s")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--pick", action="store_true", help="print step 2's pick; fail while unfinished runs could change it")
    mode.add_argument("--verification", action="store_true", help="tabulate the runs on fresh seeds (rule 4)")
    into = f"a markdown page to write the table into, between <!-- {MARKER} --> (or {VERIFICATION_MARKER}) markers"
    parser.add_argument("--into", type=Path, action="append", default=[], metavar="PAGE", help=into)
    args = parser.parse_args(argv)
    marker = VERIFICATION_MARKER if args.verification else MARKER
    require_markers(args.into, marker)
    root, tasks = args.root, suite(args.queue)
    per_run = runs(root, tasks)
    outcome, columns = decision(per_run, tasks), COLUMNS
    if args.pick or args.verification:
        picked = pick(per_run, tasks)
        if picked is None:
            sys.exit(
                "step 2's pick is undecided: the candidates' unfinished runs could change it "
                "(python benchmarks/defaults_table.py)"
            )
        if args.pick:
            print(picked)
            return
        root, tasks = args.verify_root, suite(args.verify_queue)
        per_run = runs(root, tasks)
        outcome, columns = verification(per_run, tasks, picked), verification_columns(picked)
    root.mkdir(parents=True, exist_ok=True)
    per_run.to_csv(root / "runs.csv", index=False)
    markdown = table(per_run, tasks, outcome, columns)
    (root / "table.md").write_text(markdown)
    for page in args.into:
        write_between_markers(page, marker, markdown)
    print(markdown)


if __name__ == "__main__":
    main()
