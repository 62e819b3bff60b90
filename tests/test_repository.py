"""
The repository as a clone meets it: every committed file small, but the shipped agents and the images.

Every committed byte stays in every clone's history, so a large file (a checkpoint, a video, a raw log) costs every
user for good: past commits hold 296 MiB of CarRacing checkpoints, which the README's blobless clone does not fetch.
The one exception is an unfinished run's last checkpoint, committed at a session's end so that the run resumes in
the next (issue 63's 4M-step CarRacing-v3 runs, ~10.6 MB each), and removed when the run finishes
(``tests/lab/test_benchmarks.py::test_only_unfinished_runs_keep_a_checkpoint``).
"""

import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: The most a committed file may weigh
MAX_FILE_BYTES = 2 * 2**20
#: Where larger files may be: the shipped agents and the documentation's images
LARGE_FILES_ALLOWED_UNDER = ("rl-trained-agents/", "docs/images/")


def tracked_files() -> list[str]:
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True).stdout
    return [name for name in listed.decode().split("\0") if name]


def unfinished_runs_checkpoint(name: str, tracked: set[str]) -> bool:
    """
    Whether ``name`` is the model of an unfinished run's checkpoint in a comparison folder (``per_run/``), committed so
    that a long run resumes in a later session: its state (``.checkpoint.json``) is committed and its summary (the
    ``.json`` a run writes when it finishes) is not.
    """
    if "/per_run/" not in name or not name.endswith(".checkpoint.zip"):
        return False
    run = name.removesuffix(".checkpoint.zip")
    return f"{run}.checkpoint.json" in tracked and f"{run}.json" not in tracked


def test_no_committed_file_over_2_mb() -> None:
    tracked = set(tracked_files())
    too_large = {
        name: (REPO / name).stat().st_size
        for name in tracked
        if (REPO / name).is_file()
        and not name.startswith(LARGE_FILES_ALLOWED_UNDER)
        and not unfinished_runs_checkpoint(name, tracked)
        and (REPO / name).stat().st_size > MAX_FILE_BYTES
    }
    assert not too_large, f"files over {MAX_FILE_BYTES:,} bytes outside {LARGE_FILES_ALLOWED_UNDER}: {too_large}"


@pytest.mark.parametrize(
    "name, tracked, allowed",
    [
        ("a/per_run/reinforce_seed1.checkpoint.zip", {"a/per_run/reinforce_seed1.checkpoint.json"}, True),
        ("a/per_run/reinforce_seed1.checkpoint.zip", set(), False),  # no state: not a resumable checkpoint
        (
            "a/per_run/reinforce_seed1.checkpoint.zip",  # a finished run's
            {"a/per_run/reinforce_seed1.checkpoint.json", "a/per_run/reinforce_seed1.json"},
            False,
        ),
        ("a/reinforce_seed1.checkpoint.zip", {"a/reinforce_seed1.checkpoint.json"}, False),  # outside a comparison
        ("a/per_run/video.zip", {"a/per_run/video.checkpoint.json"}, False),
    ],
)
def test_only_an_unfinished_runs_checkpoint_may_be_large(name: str, tracked: set[str], allowed: bool) -> None:
    assert unfinished_runs_checkpoint(name, tracked) is allowed
