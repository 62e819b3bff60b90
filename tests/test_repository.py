"""
The repository as a clone meets it: every committed file small, but the shipped agents and the images.

Every committed byte stays in every clone's history, so a large file (a checkpoint, a video, a raw log) costs every
user for good: past commits hold 296 MiB of CarRacing checkpoints, which the README's blobless clone does not fetch.
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


def test_no_committed_file_over_2_mb() -> None:
    too_large = {
        name: (REPO / name).stat().st_size
        for name in tracked_files()
        if (REPO / name).is_file()
        and not name.startswith(LARGE_FILES_ALLOWED_UNDER)
        and (REPO / name).stat().st_size > MAX_FILE_BYTES
    }
    assert not too_large, f"files over {MAX_FILE_BYTES:,} bytes outside {LARGE_FILES_ALLOWED_UNDER}: {too_large}"
