"""
``sb3-reinforce report DIR [DIR ...] [--readme README.md] [--summary FILE] [--figure PNG]``: rebuild the tables
and plots of result folders from their raw files, print each markdown table, and optionally write them into a
README between the markers ``<!-- results:DIR -->`` and ``<!-- /results:DIR -->``, the one-screen summary into a
file, and the results-at-a-glance figure (a panel per env) into a PNG.

A folder with ``per_run/`` is a comparison (``sb3-reinforce compare``); a folder with ``episodes_seed*.csv`` is
a seed reproduction (``sb3-reinforce seed``).
"""

import argparse
import json
import re
from pathlib import Path

import pandas as pd

from sb3_reinforce.compare.report import (
    PER_RUN_DIR,
    overview_table,
    plot_overview,
    plot_seed_curves,
    seed_table,
    to_markdown,
)
from sb3_reinforce.lab.stats import solve_threshold
from sb3_reinforce.seed_reproduction import stopped_reason

__all__ = ["build_parser", "main", "render", "render_seed", "update_readme", "write_between_markers"]


def _format_seed_table(table: pd.DataFrame) -> pd.DataFrame:
    shown = table.copy()
    for column in shown.columns:
        if column.startswith(("episodes to", "steps to")):
            shown[column] = [("not reached" if pd.isna(v) or v == float("inf") else f"{int(v):,}") for v in shown[column]]
        elif "mean" in column or column == "wall-clock s":
            # A window mean of a seed with fewer episodes than the window is NaN (see seed_table)
            window = re.search(r"(\d+)-episode", column)
            missing = f"n/a (fewer than {window.group(1)} episodes)" if window else "n/a"
            shown[column] = [missing if pd.isna(v) else f"{v:,.1f}" for v in shown[column]]
        elif column in ("steps", "episodes"):
            shown[column] = [f"{int(v):,}" for v in shown[column]]
    return shown


def render_seed(out_dir: Path) -> str:
    """
    Merge a seed reproduction's per-seed files into ``episodes.csv``, write ``summary.csv``, ``summary.md``
    and ``learning_curve.png``.

    :param out_dir: The folder of ``sb3-reinforce seed --out``
    :return: The markdown table
    """
    frames = [pd.read_csv(path) for path in sorted(out_dir.glob("episodes_seed*.csv"))]
    # Seeds that stopped before their episodes were done (sb3-reinforce seed --max-steps/--max-episode-steps)
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


def render(out_dir: Path) -> str:
    """
    Rebuild a result folder's outputs (comparison or seed reproduction) and return its markdown table.

    :param out_dir: The result folder
    :return: The markdown table
    """
    out_dir = Path(out_dir)
    if (out_dir / PER_RUN_DIR).is_dir():
        from sb3_reinforce.compare.cli import write_outputs

        meta_path = out_dir / "comparison.json"
        if meta_path.exists():
            meta = json.loads(meta_path.read_text())
            env_id, threshold = meta["env"], meta["threshold"]
        else:
            env_id = json.loads(next((out_dir / PER_RUN_DIR).glob("*.json")).read_text())["spec"]["env_id"]
            threshold = solve_threshold(env_id)
        if write_outputs(out_dir, env_id, threshold) is None:
            raise ValueError(f"{out_dir} has no finished run yet")
        return (out_dir / "summary.md").read_text()
    if any(out_dir.glob("episodes_seed*.csv")):
        return render_seed(out_dir)
    raise ValueError(f"{out_dir} is neither a comparison (per_run/) nor a seed reproduction (episodes_seed*.csv)")


def write_between_markers(path: Path, marker: str, text: str) -> bool:
    """
    Replace what stands between ``<!-- MARKER -->`` and ``<!-- /MARKER -->`` in a markdown file.

    :return: Whether the markers were found (the file is left as it was otherwise)
    """
    content = path.read_text()
    pattern = re.compile(rf"(<!-- {re.escape(marker)} -->\n).*?(<!-- /{re.escape(marker)} -->)", re.DOTALL)
    content, count = pattern.subn(lambda m: m.group(1) + text + m.group(2), content)  # text taken as is, no escapes
    if count:
        path.write_text(content)
    return bool(count)


def update_readme(readme: Path, tables: dict[str, str]) -> list[str]:
    """
    Replace the text between ``<!-- results:DIR -->`` and ``<!-- /results:DIR -->`` with each folder's table.

    :param readme: The markdown file
    :param tables: {DIR as written in the markers: markdown table}
    :return: The folders whose markers were found and updated
    """
    return [name for name, table in tables.items() if write_between_markers(readme, f"results:{name}", table)]


def build_parser() -> argparse.ArgumentParser:
    """The ``report`` command's argument parser."""
    parser = argparse.ArgumentParser(
        prog="sb3-reinforce report",
        description="Rebuild the tables and plots of result folders from their raw files and print each markdown "
        "table. A folder with per_run/ is a comparison (sb3-reinforce compare), a folder with episodes_seed*.csv a "
        "seed reproduction (sb3-reinforce seed).",
    )
    parser.add_argument("dirs", nargs="+", metavar="DIR", help="result folders")
    parser.add_argument(
        "--summary",
        type=Path,
        default=None,
        help="also write the one-screen summary of the comparison folders (one row per env and algorithm, the "
        "first folder that has it) into this markdown file, between <!-- summary --> and <!-- /summary --> "
        "(default: no file is written)",
    )
    parser.add_argument(
        "--figure",
        type=Path,
        default=None,
        help="also draw the comparison folders' learning curves into this PNG, one panel per env (the IQM over seeds "
        "with its 95%% bootstrap CI, the threshold), the envs and algorithms of --summary (default: no figure)",
    )
    parser.add_argument(
        "--readme",
        type=Path,
        default=None,
        help="also write each table into this markdown file, between the markers <!-- results:DIR --> and "
        "<!-- /results:DIR --> (default: no file is written)",
    )
    return parser


def main(argv: list[str] | None = None) -> None:
    """Command line entry point (see the module docstring)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    tables = {}
    for name in args.dirs:
        try:
            tables[name.rstrip("/")] = render(Path(name))
        except ValueError as error:
            parser.error(str(error))
        print(f"## {name}\n\n{tables[name.rstrip('/')]}")
    comparisons = [Path(name) for name in args.dirs if (Path(name) / PER_RUN_DIR).is_dir()]
    if args.figure is not None:
        plot_overview(comparisons, args.figure)
        print(f"{args.figure}: figure written")
    if args.summary is not None:
        try:
            overview = to_markdown(overview_table(comparisons))
        except ValueError as error:
            parser.error(str(error))
        print(f"## Summary\n\n{overview}")
        if not write_between_markers(args.summary, "summary", overview):
            parser.error(f"{args.summary} has no <!-- summary --> and <!-- /summary --> markers")
        print(f"{args.summary}: summary updated")
    if args.readme is not None:
        updated = update_readme(args.readme, tables)
        missing = sorted(set(tables) - set(updated))
        print(f"{args.readme}: updated {updated}" + (f"; no markers for {missing}" if missing else ""))
