"""
The test files of the *installed* stable-baselines3, taken from its source distribution on the package index.

SB3's wheel has no tests; its sdist ships ``tests/``. The sdist of the installed version is downloaded once
with ``pip download`` and only its ``tests/*.py`` are extracted, into a cache shared by every run and every
pytest-xdist worker::

    $SB3_REINFORCE_CACHE_DIR (default: $XDG_CACHE_HOME/sb3-reinforce, i.e. ~/.cache/sb3-reinforce)
        sb3-tests/<version>/tests/test_*.py

Nothing of SB3's is ever copied into this repository: the files are read from the cache at test time.
"""

import contextlib
import importlib.metadata
import os
import pathlib
import shutil
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Iterator

__all__ = ["SB3TestsUnavailable", "cache_dir", "installed_sb3_version", "sb3_tests_dir"]

DISTRIBUTION = "stable-baselines3"
#: Most seconds ``pip download`` may take (it retries by itself before that on a flaky network)
DOWNLOAD_TIMEOUT_S = 300


class SB3TestsUnavailable(RuntimeError):
    """The sdist of the installed SB3 could not be downloaded or read."""


def installed_sb3_version() -> str:
    return importlib.metadata.version(DISTRIBUTION)


def cache_dir() -> pathlib.Path:
    """Where the extracted tests are kept: ``$SB3_REINFORCE_CACHE_DIR``, else ``$XDG_CACHE_HOME/sb3-reinforce``."""
    if os.environ.get("SB3_REINFORCE_CACHE_DIR"):
        return pathlib.Path(os.environ["SB3_REINFORCE_CACHE_DIR"]).expanduser()
    xdg_cache = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(xdg_cache) / "sb3-reinforce"


@contextlib.contextmanager
def _exclusive_lock(path: pathlib.Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (POSIX), so that pytest-xdist workers download the sdist once."""
    try:
        import fcntl
    except ImportError:  # no fcntl (Windows): concurrent workers may each download it, the rename below stays atomic
        yield
        return
    with open(path, "w") as lock_file:
        fcntl.flock(lock_file, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock_file, fcntl.LOCK_UN)


def _download_sdist(version: str, destination: pathlib.Path) -> pathlib.Path:
    command = [
        sys.executable,
        "-m",
        "pip",
        "download",
        "--quiet",
        "--no-deps",
        "--no-binary",
        ":all:",
        f"{DISTRIBUTION}=={version}",
        "-d",
        str(destination),
    ]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=DOWNLOAD_TIMEOUT_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        raise SB3TestsUnavailable(f"`{' '.join(command)}` failed: {error}") from error
    archives = sorted(destination.glob("*.tar.gz"))
    if result.returncode != 0 or not archives:
        output = (result.stderr or result.stdout).strip().splitlines()[-3:]
        raise SB3TestsUnavailable(f"`{' '.join(command)}` failed (exit {result.returncode}): {' / '.join(output)}")
    return archives[0]


def _extract_tests(archive: pathlib.Path, destination: pathlib.Path) -> None:
    """Extract the top-level ``tests/*.py`` of the sdist (and nothing else) into ``destination``."""
    destination.mkdir(parents=True)
    with tarfile.open(archive) as tar:
        for member in tar.getmembers():
            parts = pathlib.PurePosixPath(member.name).parts
            # <name>-<version>/tests/test_x.py: plain files directly in tests/, no links or nested paths
            if len(parts) == 3 and parts[1] == "tests" and parts[2].endswith(".py") and member.isfile():
                source = tar.extractfile(member)
                assert source is not None
                (destination / parts[2]).write_bytes(source.read())
    if not any(destination.glob("test_*.py")):
        raise SB3TestsUnavailable(f"{archive.name} has no tests/test_*.py")


def sb3_tests_dir(version: str | None = None) -> pathlib.Path:
    """
    The folder of the test files of SB3 ``version`` (default: the installed one), downloaded and extracted
    on the first call (then read from the cache).

    :raises SB3TestsUnavailable: when the sdist cannot be downloaded (no network, no such version on the index)
    """
    version = version or installed_sb3_version()
    root = cache_dir() / "sb3-tests"
    tests_dir = root / version / "tests"
    if tests_dir.is_dir():
        return tests_dir
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise SB3TestsUnavailable(f"cannot create the cache folder {root}: {error}") from error
    with _exclusive_lock(root / f".{version}.lock"):
        if tests_dir.is_dir():  # another worker got it while we waited
            return tests_dir
        with tempfile.TemporaryDirectory(dir=root, prefix=f".{version}-") as scratch:
            scratch_path = pathlib.Path(scratch)
            archive = _download_sdist(version, scratch_path / "sdist")
            staged = scratch_path / "tests"
            try:
                _extract_tests(archive, staged)
            except (tarfile.TarError, OSError) as error:
                raise SB3TestsUnavailable(f"cannot read {archive.name}: {error}") from error
            tests_dir.parent.mkdir(parents=True, exist_ok=True)
            try:
                staged.rename(tests_dir)  # atomic: the folder is complete whenever it exists
            except OSError:
                if not tests_dir.is_dir():
                    raise
                shutil.rmtree(staged, ignore_errors=True)
    return tests_dir
