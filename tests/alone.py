"""
Tests marked ``alone`` run with no other test beside them, also under pytest-xdist (the README's ``-n auto``).

Such a test measures wall-clock throughput (SB3's ``test_fps_logger``): beside another worker's CPU-bound test on a
2-core machine, it measures that test. Every test takes the shared side of an inter-process reader-writer lock for
its setup, call and teardown, and an ``alone`` test the exclusive side. An ``alone`` test first takes a turnstile
that every test passes through before its shared lock, so once it waits, no worker starts another test: the running
ones finish, then it runs, then the others go on. The locks are fasteners' (``fcntl``), in the session's temporary
folder that the workers share. Without xdist (one process), tests run one at a time anyway and nothing is locked.
"""

import os
from collections.abc import Iterator

import fasteners
import pytest

#: The marker: ``@pytest.mark.alone`` (registered in pyproject.toml)
ALONE = "alone"


@pytest.fixture(autouse=True)
def run_alone_when_marked(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The shared side of the lock for every test, the exclusive side for an ``alone`` test (see the module)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        yield
        return
    shared_folder = tmp_path_factory.getbasetemp().parent  # the workers' folders are popen-gw0, popen-gw1, ... in it
    turnstile = fasteners.InterProcessLock(shared_folder / "alone.turnstile")
    tests = fasteners.InterProcessReaderWriterLock(shared_folder / "alone.lock")
    if request.node.get_closest_marker(ALONE) is not None:
        with turnstile, tests.write_lock():
            yield
    else:
        with turnstile:
            pass
        with tests.read_lock():
            yield
