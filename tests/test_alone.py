"""The ``alone`` marker (tests/alone.py): under pytest-xdist, no other test runs beside a test that has it."""

import itertools
import pathlib

import pytest

pytest_plugins = ["pytester"]

REPOSITORY = pathlib.Path(__file__).resolve().parents[1]

#: Tests of an inner session: each writes when it started and ended; ``test_timed`` is marked ``alone``
INNER_TESTS = """
import os, time
import pytest

def record(name, seconds):
    start = time.monotonic()
    time.sleep(seconds)
    with open(os.path.join(os.environ["INTERVALS"], name), "w") as file:
        file.write(f"{start} {time.monotonic()}")

@pytest.mark.parametrize("index", range(6))
def test_before(index):
    record(f"before{index}", 0.4)

@pytest.mark.alone
def test_timed():
    record("timed", 1.0)

@pytest.mark.parametrize("index", range(6))
def test_after(index):
    record(f"after{index}", 0.4)
"""


def test_an_alone_test_runs_with_no_other_test_beside_it(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, tmp_path: pathlib.Path
) -> None:
    intervals = tmp_path / "intervals"
    intervals.mkdir()
    monkeypatch.setenv("INTERVALS", str(intervals))
    monkeypatch.setenv("PYTHONPATH", str(REPOSITORY))
    pytester.makeconftest("from tests.alone import run_alone_when_marked  # noqa: F401")
    pytester.makeini("[pytest]\nmarkers =\n    alone: runs alone\n")
    pytester.makepyfile(test_inner=INNER_TESTS)
    result = pytester.runpytest_subprocess("-n", "2", "-p", "xdist", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=13)
    spans = {path.name: tuple(map(float, path.read_text().split())) for path in intervals.iterdir()}
    assert len(spans) == 13
    timed_start, timed_end = spans.pop("timed")
    beside = [name for name, (start, end) in spans.items() if start < timed_end and end > timed_start]
    assert not beside, f"ran beside the alone test: {beside}"
    # the two workers did run tests side by side (else the check above could not fail)
    ordered = sorted(spans.values())
    assert any(later[0] < earlier[1] for earlier, later in itertools.pairwise(ordered))
