"""Commands that need an optional extra say which one to install, in one line, instead of a traceback."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    "argv, extra, missing",
    [
        (["sb3_reinforce.lab.cli", "compare", "--env", "CartPole-v1"], "compare", "pandas"),
        (["sb3_reinforce.lab.cli", "report", "."], "compare", "pandas"),
        (["sb3_reinforce.lab.zoo", "benchmark", "--help"], "zoo", "pandas"),
        # Dask's distributed runs the runs of compare and seed
        (["sb3_reinforce.lab.cli", "compare", "--env", "CartPole-v1"], "compare", "distributed"),
        (["sb3_reinforce.lab.cli", "seed", "--env", "CartPole-v1", "--out", "never_written"], "compare", "distributed"),
    ],
)
def test_a_missing_extra_is_named(argv: list[str], extra: str, missing: str) -> None:
    # Without a module of the extra, the command names the extra to install instead of a traceback
    code = f"import runpy, sys; sys.modules[{missing!r}] = None; "
    code += f"sys.argv = {argv!r}; runpy.run_module({argv[0]!r}, run_name='__main__')"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert not (REPO / "never_written").exists(), "refused before anything is written"
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'sb3-reinforce[{extra}]'" in lines[0], lines
