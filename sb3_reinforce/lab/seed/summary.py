"""The report of a seed reproduction's folder (``sb3-reinforce seed --out``): table, learning curve, early stops."""

import json
import re
from pathlib import Path

import pandas as pd

from sb3_reinforce.lab.compare.figures import plot_seed_curves, seed_table, to_markdown
from sb3_reinforce.lab.stats import solve_threshold

__all__ = ["render_seed", "stopped_reason"]


def stopped_reason(path: Path) -> str:
    """
    Why a seed stopped early, from its ``episodes_seedN.stopped`` file.

    :param path: The ``.stopped`` file
    :return: One line, e.g. "seed 0 stopped after 114 of 500 episodes: the step cap of ... was reached"
    """
    return str(json.loads(path.read_text())["reason"])


def _format_seed_table(table: pd.DataFrame) -> pd.DataFrame:
    shown = table.copy()
    for column in shown.columns:
        if column.startswith(("episodes to", "steps to")):
            shown[column] = [("not reached" if pd.isna(v) or v == float("inf") else f"{int(v):,}") for v in shown[column]]
        elif "mean" in column or column == "wall-clock s":
            # NaN: fewer episodes than the window
            window = re.search(r"(\d+)-episode", column)
            missing = f"n/a (fewer than {window.group(1)} episodes)" if window else "n/a"
            shown[column] = [missing if pd.isna(v) else f"{v:,.1f}" for v in shown[column]]
        elif column in ("steps", "episodes"):
            shown[column] = [f"{int(v):,}" for v in shown[column]]
    return shown


def render_seed(out_dir: Path) -> str:
    """
    Merge the per-seed files into ``episodes.csv``; write ``summary.csv``, ``summary.md``, ``learning_curve.png``.

    :param out_dir: The folder of ``sb3-reinforce seed --out``
    :return: The markdown table
    """
    frames = [pd.read_csv(path) for path in sorted(out_dir.glob("episodes_seed*.csv"))]
    # Seeds stopped early by --max-steps/--max-episode-steps
    stops = "".join(f"- {stopped_reason(path)}\n" for path in sorted(out_dir.glob("episodes_seed*.stopped")))
    finished = [f for f in frames if len(f)]
    if not finished:
        markdown = "No training episode finished.\n" + (f"\n{stops}" if stops else "")
        (out_dir / "summary.md").write_text(markdown)
        return markdown
    episodes = pd.concat(finished, ignore_index=True)
    episodes.to_csv(out_dir / "episodes.csv", index=False)
    env_id = str(episodes["env"].iloc[0])
    threshold = solve_threshold(env_id)
    if threshold is None:
        raise ValueError(f"{out_dir}: {env_id} has no solve threshold (no reward_threshold in its Gymnasium spec)")
    table = seed_table(episodes, threshold)
    table.to_csv(out_dir / "summary.csv", index=False)
    markdown = to_markdown(_format_seed_table(table))
    if stops:
        markdown = markdown.rstrip("\n") + "\n\n" + stops
    (out_dir / "summary.md").write_text(markdown)
    plot_seed_curves(episodes, threshold, out_dir / "learning_curve.png", f"{env_id}: the seed's agent")
    return markdown
