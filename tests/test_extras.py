"""Commands that need an optional extra say which one to install, in one line, instead of a traceback."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "argv, extra",
    [
        (["sb3_reinforce.cli", "compare", "--env", "CartPole-v1"], "compare"),
        (["sb3_reinforce.cli", "report", "."], "compare"),
        (["sb3_reinforce.lab.zoo", "benchmark", "--help"], "zoo"),
    ],
)
def test_a_missing_extra_is_named(argv: list[str], extra: str) -> None:
    # pandas comes with both extras: without it, the command names the extra to install instead of a traceback
    code = "import runpy, sys; sys.modules['pandas'] = None; "
    code += f"sys.argv = {argv!r}; runpy.run_module({argv[0]!r}, run_name='__main__')"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'sb3-reinforce[{extra}]'" in lines[0], lines
