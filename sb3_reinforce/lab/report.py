"""
``sb3-reinforce report DIR [DIR ...] [--readme README.md] [--summary FILE] [--figure PNG] [--published CSV
[--published-algo ALGO] [--published-into FILE]]``: rebuild result folders' tables and plots, print their markdown
tables and optionally write them into markdown files between ``<!-- MARKER -->`` comments.
"""

import argparse
import re
from pathlib import Path

import pandas as pd

from sb3_reinforce.lab.compare.command import write_outputs
from sb3_reinforce.lab.compare.experiment import known_algos
from sb3_reinforce.lab.compare.figures import (
    overview_table,
    plot_overview,
    published_table,
    to_markdown,
)
from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.provenance import differences
from sb3_reinforce.lab.seed.summary import render_seed

__all__ = [
    "build_parser",
    "main",
    "page_table",
    "published_marker",
    "render",
    "require_markers",
    "system_differences",
    "update_readme",
    "write_between_markers",
]


def render(out_dir: Path) -> str:
    """
    Rebuild a result folder's outputs (comparison or seed reproduction) and return its markdown table.

    :param out_dir: The result folder
    :return: The markdown table
    """
    out_dir = Path(out_dir)
    if ComparisonFolder.holds_comparison(out_dir):
        folder = ComparisonFolder(out_dir)
        env_id, threshold = folder.read_meta()
        if write_outputs(out_dir, env_id, threshold) is None:
            raise ValueError(f"{out_dir} has no finished run yet")
        return folder.output(folder.SUMMARY_MD).read_text()
    if any(out_dir.glob("episodes_seed*.csv")):
        return render_seed(out_dir)
    raise ValueError(f"{out_dir} is neither a comparison (per_run/) nor a seed reproduction (episodes_seed*.csv)")


#: A page's copy of a comparison's table leaves out the columns whose header starts so: the seconds of runs made at
#: different times on differently loaded machines answer no question across algorithms (the folder's own summary.md
#: keeps them; benchmarks/wallclock_table.py measures training time side by side).
PAGE_OMITS = "seconds to "


def page_table(out_dir: Path, rendered: str) -> str:
    """
    A result folder's table as ``--readme`` writes it into a page: a comparison's without its seconds to the threshold.

    :param out_dir: The result folder, after :func:`render`
    :param rendered: What :func:`render` returned for it
    :return: The markdown table
    """
    if not ComparisonFolder.holds_comparison(out_dir):
        return rendered  # a seed reproduction's table counts episodes, not seconds
    folder = ComparisonFolder(out_dir)
    table = pd.read_csv(folder.output(folder.SUMMARY_CSV), dtype=str, keep_default_na=False)  # the cells as written
    return to_markdown(table.drop(columns=[column for column in table.columns if column.startswith(PAGE_OMITS)]))


def system_differences(folders: list[Path]) -> str | None:
    """
    Where the finished runs of comparison folders were made under different versions, CPU types or torch threads
    (their summaries' ``system``, or each part's for a resumed run), one line saying which: such runs are not
    reproducible bit for bit from one another. Runs made before systems were recorded are counted, not compared.

    :param folders: Comparison folders
    :return: The line, or None where every run recorded the same (or none recorded any)
    """
    summaries = [summary for folder in folders for summary in ComparisonFolder(folder).load_summaries().values()]
    # a resumed run records each part's system (None: a part made before systems were recorded)
    parts = [summary.get("systems", [summary.get("system")]) for summary in summaries]
    systems = [system for run in parts for system in run if system is not None]
    unrecorded = sum(any(system is None for system in run) for run in parts)
    notes = []
    found = differences(systems)
    if found:
        listed = "; ".join(f"{key}: {', '.join(values)}" for key, values in found.items())
        notes.append(f"these runs were made under different {', '.join(found)} ({listed})")
    if unrecorded and systems:
        notes.append(
            f"{unrecorded} of {len(parts)} runs recorded no system (made before it was recorded): whether they were "
            "made under the same versions and CPU type is unknown"
        )
    return "Note: " + "; ".join(notes) if notes else None


def _marker_pattern(marker: str) -> re.Pattern[str]:
    """``<!-- MARKER -->``, a newline, anything, ``<!-- /MARKER -->``: the span :func:`write_between_markers` replaces."""
    return re.compile(rf"(<!-- {re.escape(marker)} -->\n).*?(<!-- /{re.escape(marker)} -->)", re.DOTALL)


def write_between_markers(path: Path, marker: str, text: str) -> bool:
    """
    Replace what stands between ``<!-- MARKER -->`` and ``<!-- /MARKER -->`` in a markdown file.

    :param path: The markdown file
    :param marker: The marker's name
    :param text: The new text, taken as is
    :return: Whether the markers were found (the file is left as it was otherwise)
    """
    content = path.read_text()
    content, count = _marker_pattern(marker).subn(lambda m: m.group(1) + text + m.group(2), content)  # text as is
    if count:
        path.write_text(content)
    return bool(count)


def require_markers(pages: list[Path], marker: str, option: str = "--into") -> None:
    """
    Exit with a message naming ``option`` and the page if a page lacks the ``MARKER`` pair, before any page is written.

    A page without the markers is a mistake in the command: checking every page first leaves them all as they were.

    :param pages: The markdown files the command will write into
    :param marker: The marker's name
    :param option: The command-line option that named the pages, for the message
    """
    for page in pages:
        if not _marker_pattern(marker).search(page.read_text()):
            raise SystemExit(f"{option} {page}: no <!-- {marker} --> ... <!-- /{marker} --> markers in it")


def published_marker(algo: str) -> str:
    """The marker between which ``--published-into`` writes ``algo``'s published table (REINFORCE's: ``published``)."""
    return "published" if algo == "reinforce" else f"published:{algo}"


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
    parser.add_argument("dirs", nargs="*", metavar="DIR", help="result folders (at least one, but with --published)")
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
        "--published",
        type=Path,
        default=None,
        help="also print the published results of this CSV (env_id, source, budget, mean, std; e.g. "
        "benchmarks/published/reinforce_mujoco.csv) beside --published-algo's in the comparison folders, by the "
        "published metric: the best mean over seeds of the evaluation return (default: no such table)",
    )
    parser.add_argument(
        "--published-algo",
        default="reinforce",
        metavar="ALGO",
        help="with --published: the algorithm of the comparison folders held against it, one rl_zoo3 knows "
        "(default: reinforce)",
    )
    parser.add_argument(
        "--published-into",
        type=Path,
        default=None,
        help="with --published: also write that table into this markdown file, between <!-- published --> and "
        "<!-- /published --> (for another --published-algo than reinforce: <!-- published:ALGO --> and "
        "<!-- /published:ALGO -->) (default: no file is written)",
    )
    parser.add_argument(
        "--readme",
        type=Path,
        default=None,
        help="also write each table into this markdown file, between the markers <!-- results:DIR --> and "
        "<!-- /results:DIR -->, a comparison's without its seconds to the threshold (runs made apart compare no "
        "time; summary.md keeps them) (default: no file is written)",
    )
    return parser


def _published(parser: argparse.ArgumentParser, args: argparse.Namespace, comparisons: list[Path]) -> None:
    """Print (and with ``--published-into`` write) the published table of ``--published`` beside the comparisons'."""
    if not args.published.is_file():
        parser.error(f"--published: no such file {args.published}")
    if args.published_algo not in known_algos():
        parser.error(f"--published-algo: unknown algorithm {args.published_algo!r} (one of: {known_algos()})")
    published = to_markdown(published_table(comparisons, pd.read_csv(args.published), args.published_algo))
    print(f"## Published results\n\n{published}")
    if args.published_into is not None:
        marker = published_marker(args.published_algo)
        if not write_between_markers(args.published_into, marker, published):
            parser.error(f"{args.published_into} has no <!-- {marker} --> and <!-- /{marker} --> markers")
        print(f"{args.published_into}: published table updated")


def main(argv: list[str] | None = None) -> None:
    """Command line entry point (see the module docstring)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.dirs and args.published is None:
        parser.error("give at least one result folder DIR")
    tables = {}
    for name in args.dirs:
        try:
            tables[name.rstrip("/")] = render(Path(name))
        except ValueError as error:
            parser.error(str(error))
        print(f"## {name}\n\n{tables[name.rstrip('/')]}")
    comparisons = [Path(name) for name in args.dirs if ComparisonFolder.holds_comparison(Path(name))]
    note = system_differences(comparisons)
    if note is not None:
        print(note)
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
    if args.published is None and (args.published_into is not None or args.published_algo != "reinforce"):
        parser.error("--published-into and --published-algo need --published CSV")
    if args.published is not None:
        _published(parser, args, comparisons)
    if args.readme is not None:
        updated = update_readme(args.readme, {name: page_table(Path(name), table) for name, table in tables.items()})
        missing = sorted(set(tables) - set(updated))
        print(f"{args.readme}: updated {updated}" + (f"; no markers for {missing}" if missing else ""))
