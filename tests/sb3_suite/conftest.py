"""Collects stable-baselines3's own tests, run with REINFORCE in A2C's and PPO's place (see suite.py)."""

import os
import pathlib
from collections.abc import Iterator

import pytest

from tests.sb3_suite.suite import TEST_FILES_LIST, SB3Suite


def pytest_collect_file(file_path: pathlib.Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path == TEST_FILES_LIST:
        return SB3Suite.from_parent(parent, path=file_path)
    return None


def pytest_configure(config: pytest.Config) -> None:
    # SB3's own marker (registered in SB3's pyproject.toml, which is not read here)
    config.addinivalue_line("markers", "expensive: SB3's expensive tests")


@pytest.fixture(autouse=True)
def _restore_environment_variables() -> Iterator[None]:
    # SB3's test_logger.py::test_set_logger sets SB3_LOGDIR and leaves it set: keep it from reaching later tests
    saved = dict(os.environ)
    yield
    os.environ.clear()
    os.environ.update(saved)
