"""
The code examples of README.md and docs/ are executed, so they cannot rot: every ```python block of a page
runs, in order, in one namespace per page, in a temporary working directory (examples save files).
"""

import os
import re
from pathlib import Path

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


#: The README's command that writes its one-screen summary (the comparison folders, in the order of the rows)
SUMMARY_COMMAND = re.compile(r"`sb3-reinforce report ((?:benchmarks/results/\S+ )+)--summary README\.md`")


def test_readme_summary_is_the_committed_results(monkeypatch: pytest.MonkeyPatch) -> None:
    # The README's results table is what `report --summary` makes of the committed folders, so it cannot go stale
    from sb3_reinforce.compare.report import overview_table, to_markdown

    readme = (REPO / "README.md").read_text()
    command = SUMMARY_COMMAND.search(readme)
    assert command is not None, "the README names the command that writes its summary"
    monkeypatch.chdir(REPO)  # the folders as the README names them, relative to the repository root
    folders = [Path(name) for name in command.group(1).split()]
    block = re.search(r"<!-- summary -->\n(.*?)<!-- /summary -->", readme, re.DOTALL)
    assert block is not None
    assert block.group(1) == to_markdown(overview_table(folders))
