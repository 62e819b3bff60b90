"""
The code examples of README.md and docs/ are executed, so they cannot rot: every ```python block of a page
runs, in order, in one namespace per page, in a temporary working directory (examples save files).
"""

import json
import os
import re
from pathlib import Path

import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def python_blocks(page: Path) -> list[str]:
    return PYTHON_BLOCK.findall(page.read_text())


def test_pages_have_examples() -> None:
    # The regular expression finds the blocks: the README and the algorithm page each have one at least
    assert python_blocks(REPO / "README.md") and python_blocks(REPO / "docs" / "modules" / "reinforce.md")


@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p)], ids=lambda p: str(p.relative_to(REPO)))
def test_examples_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__docs__"}
    for number, block in enumerate(python_blocks(page)):
        code = compile(block, f"{page.relative_to(REPO)} [python block {number}]", "exec")
        exec(code, namespace)
    assert os.getcwd() == str(tmp_path)


#: The command that writes a page's one-screen summary (the comparison folders, in the order of the rows), and on
#: the results page its figure too
SUMMARY_COMMAND = r"`sb3-reinforce report ((?:benchmarks/results/\S+ )+)--summary {page}(?: --figure (\S+))?`"


@pytest.mark.parametrize("page", ["README.md", "docs/results.md"])
def test_summary_is_the_committed_results(page: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # The results tables of the README and of the results page are what `report --summary` makes of the committed
    # folders, so they cannot go stale; the results page opens with the figure the same command draws
    from sb3_reinforce.lab.compare.figures import overview_table, plot_overview, to_markdown

    text = (REPO / page).read_text()
    command = re.search(SUMMARY_COMMAND.format(page=re.escape(page)), text)
    assert command is not None, f"{page} names the command that writes its summary"
    monkeypatch.chdir(REPO)  # the folders as the pages name them, relative to the repository root
    folders = [Path(name) for name in command.group(1).split()]
    block = re.search(r"<!-- summary -->\n(.*?)<!-- /summary -->", text, re.DOTALL)
    assert block is not None
    assert block.group(1) == to_markdown(overview_table(folders))
    if page == "docs/results.md":
        figure = Path(command.group(2))
        assert text.startswith("# Results\n\n![") and f"]({figure.relative_to('docs')})" in text.split("\n")[2]
        assert figure.is_file()
        axes = plot_overview(folders, tmp_path / "figure.png").axes
        assert [ax.get_title() for ax in axes if ax.get_title()] == list(
            dict.fromkeys(row.split(" (")[0] for row in overview_table(folders)["env (threshold)"])
        )


#: The command that writes a page's table of published results (the comparison folders, the CSV, the algorithm held
#: against it), and on the results page its figure too
PUBLISHED_COMMAND = (
    r"`sb3-reinforce report ((?:benchmarks/results/\S+ )*)--published (\S+)(?: --published-algo (\S+))? "
    r"--published-into {page}(?: --figure (\S+))?`"
)


@pytest.mark.parametrize("page", ["docs/results.md"])
def test_published_table_is_the_committed_results(page: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # The MuJoCo tables of the results page are what `report --published` makes of the committed
    # folders and the published numbers' CSV, so they cannot go stale (REINFORCE's against the published REINFORCE,
    # and on the results page PPO's against rl_zoo3's published PPO); the results page shows the figure the same
    # command draws, one panel per env of the folders
    from sb3_reinforce.lab.compare.figures import plot_overview, published_table, to_markdown
    from sb3_reinforce.lab.report import published_marker

    text = (REPO / page).read_text()
    commands = list(re.finditer(PUBLISHED_COMMAND.format(page=re.escape(page)), text))
    assert commands, f"{page} names the command that writes its published table"
    monkeypatch.chdir(REPO)
    for command in commands:
        folders = [Path(name) for name in command.group(1).split()]
        algo = command.group(3) or "reinforce"
        marker = published_marker(algo)
        block = re.search(rf"<!-- {marker} -->\n(.*?)<!-- /{marker} -->", text, re.DOTALL)
        assert block is not None
        published = pd.read_csv(command.group(2))
        assert block.group(1) == to_markdown(published_table(folders, published, algo))
        if command.group(4) is not None:
            figure = Path(command.group(4))
            assert figure.is_file() and f"]({figure.relative_to('docs')})" in text
            axes = plot_overview(folders, tmp_path / "figure.png").axes
            envs = [json.loads((folder / "comparison.json").read_text())["env"] for folder in folders]
            assert [ax.get_title() for ax in axes if ax.get_title()] == envs
        if algo == "reinforce":
            assert len(published["env_id"].unique()) == 9  # the nine envs of Tianshou's table
    if page == "docs/results.md":
        # REINFORCE's table with the figure, then PPO's
        assert [(command.group(3), command.group(4) is not None) for command in commands] == [(None, True), ("ppo", False)]


#: The commands that write the defaults study's tables (issue 62) into the results page
DEFAULTS_COMMAND = r"`python benchmarks/defaults_table.py( --verification)? --into docs/results.md`"


def test_defaults_tables_are_the_committed_results(monkeypatch: pytest.MonkeyPatch) -> None:
    # The results page's defaults tables (tuning seeds, fresh seeds) are what benchmarks/defaults_table.py makes of
    # the committed runs, and the page names the command that writes each
    import sys

    text = (REPO / "docs/results.md").read_text()
    commands = re.findall(DEFAULTS_COMMAND, " ".join(text.split()))
    assert commands == ["", " --verification"], "the page names both commands, the tuning table's first"
    monkeypatch.chdir(REPO)
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    sys.modules.pop("defaults_table", None)
    import defaults_table

    tasks = defaults_table.suite()
    per_run = defaults_table.runs(defaults_table.RESULTS, tasks)
    expected = {defaults_table.MARKER: defaults_table.table(per_run, tasks, defaults_table.decision(per_run, tasks))}
    picked = defaults_table.pick(per_run, tasks)
    if picked is not None:
        verify_tasks = defaults_table.suite(defaults_table.RESULTS / "verify_queue.sh")
        verify_runs = defaults_table.runs(defaults_table.RESULTS / "verify", verify_tasks)
        outcome = defaults_table.verification(verify_runs, verify_tasks, picked)
        columns = defaults_table.verification_columns(picked)
        expected[defaults_table.VERIFICATION_MARKER] = defaults_table.table(verify_runs, verify_tasks, outcome, columns)
    for marker, table in expected.items():
        block = re.search(rf"<!-- {marker} -->\n(.*?)<!-- /{marker} -->", text, re.DOTALL)
        assert block is not None, f"docs/results.md has the <!-- {marker} --> table"
        assert block.group(1) == table


#: The command that writes the training-time table (issue 64) into the README and the results page
WALLCLOCK_COMMAND = r"`python benchmarks/wallclock_table.py((?: --current \S+)*)((?: --into \S+)+)`"


@pytest.mark.parametrize("page", ["README.md", "docs/results.md"])
def test_wallclock_table_is_the_committed_results(page: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # The side-by-side training-time table is what benchmarks/wallclock_table.py makes of the committed runs, and the
    # command each page names writes both pages
    import sys

    text = (REPO / page).read_text()
    command = re.search(WALLCLOCK_COMMAND, " ".join(text.split()))
    assert command is not None, f"{page} names the command that writes its training-time table"
    assert sorted(command.group(2).split()[1::2]) == ["README.md", "docs/results.md"]
    monkeypatch.chdir(REPO)
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    sys.modules.pop("wallclock_table", None)
    import wallclock_table

    root = wallclock_table.RESULTS
    candidates = [wallclock_table.runs(Path(folder)) for folder in command.group(1).split()[1::2]]
    block = re.search(r"<!-- wallclock -->\n(.*?)<!-- /wallclock -->", text, re.DOTALL)
    assert block is not None
    assert block.group(1) == wallclock_table.page_table(wallclock_table.current_runs(wallclock_table.runs(root), candidates))
