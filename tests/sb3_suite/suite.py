"""
Collect stable-baselines3's own tests with REINFORCE in the place of A2C and PPO (``differences.md`` beside this
file says what is collected, how to run it, and where REINFORCE legitimately differs).

The collection tree, under ``tests/sb3_suite/sb3_test_files.txt`` (the list of SB3's test files to run)::

    SB3Suite                      sb3_test_files.txt
      SB3Variant                  ::no-baseline, ::value-baseline (REINFORCE's ``baseline``)
        SB3TestModule             ::test_run.py (read from the cached sdist, see ``sdist.py``)
          SB3's test functions    ::test_a2c[CartPole-v1]

so a test id reads ``tests/sb3_suite/sb3_test_files.txt::value-baseline::test_run.py::test_a2c[CartPole-v1]``.
"""

import dataclasses
import dis
import importlib.util
import os
import pathlib
import re
import sys
import types
from collections.abc import Iterable, Iterator
from typing import Any
from unittest import mock

import cloudpickle
import pytest
import stable_baselines3
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from tests.sb3_suite.sdist import SB3TestsUnavailable, installed_sb3_version, sb3_tests_dir
from tests.sb3_suite.substitutes import ReinforceInPlaceOf, make_substitutes

HERE = pathlib.Path(__file__).parent
TEST_FILES_LIST = HERE / "sb3_test_files.txt"
DIFFERENCES_FILE = HERE / "differences.md"

#: Variant name -> REINFORCE's baseline in that variant
VARIANTS: dict[str, str | None] = {"no-baseline": None, "value-baseline": "value"}
#: Variant column of the difference list -> the variants an entry applies to
BASELINE_COLUMN = {"both": tuple(VARIANTS), "none": ("no-baseline",), "value": ("value-baseline",)}
OUTCOMES = ("xfail", "rerun", "not run")
#: A test of wall-clock throughput runs alone (tests/alone.py) and, failed because the machine was busy anyway, runs
#: again this many times, this many seconds apart (pytest-rerunfailures' ``flaky`` marker; differences.md gives the
#: CI runs whose load outlasted fewer, shorter reruns); only its
#: ``AssertionError`` is retried, never an exception
RERUNS, RERUNS_DELAY_S = 4, 30

#: The collector records here, per variant, the ids of SB3's tests it collected (before any -k/-m selection)
collected_ids: pytest.StashKey[dict[str, set[str]]] = pytest.StashKey()
#: The rows of differences.md, read once per session
differences_key: pytest.StashKey[list["Difference"]] = pytest.StashKey()


def running_in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in {"true", "1", "yes"}


# --- the difference list ---------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Difference:
    """One row of ``differences.md``: SB3 tests on which REINFORCE legitimately differs, and why."""

    pattern: str  # "test_file.py::test_name[params]", where * matches any characters
    variants: tuple[str, ...]
    outcome: str  # "xfail" (strict), "rerun" (on a failed assertion) or "not run"
    reason: str

    def matches(self, test_id: str, variant: str) -> bool:
        regex = ".*".join(re.escape(part) for part in self.pattern.split("*"))
        return variant in self.variants and re.fullmatch(regex, test_id) is not None


def read_differences(path: pathlib.Path = DIFFERENCES_FILE) -> list[Difference]:
    """
    The rows of the Markdown tables of ``path`` whose first cell is a backquoted test id:
    ``| `test_file.py::test_name[params]` | both/none/value | xfail/rerun/not run | reason |``.
    """
    differences = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.startswith("| `"):
            continue
        cells = [cell.strip() for cell in line.strip().strip("|").split(" | ")]
        if len(cells) != 4:
            raise ValueError(f"{path.name}:{number}: expected 4 cells (test | baseline | outcome | reason): {line}")
        pattern, baseline, outcome, reason = cells
        if baseline not in BASELINE_COLUMN or outcome not in OUTCOMES or not reason:
            raise ValueError(
                f"{path.name}:{number}: baseline must be one of {sorted(BASELINE_COLUMN)}, outcome one of {OUTCOMES}, "
                f"and a reason is needed: {line}"
            )
        differences.append(Difference(pattern.strip("`"), BASELINE_COLUMN[baseline], outcome, reason))
    return differences


def read_test_files(path: pathlib.Path = TEST_FILES_LIST) -> list[str]:
    """The SB3 test files to run: one name a line, ``#`` starts a comment."""
    names = [line.split("#", 1)[0].strip() for line in path.read_text().splitlines()]
    return [name for name in names if name]


# --- which of SB3's tests exercise an on-policy algorithm -------------------------------------------------
def _members(value: Any) -> Iterator[Any]:
    """``value`` and, for a container, what it holds (two levels: a dict of tuples, a list of classes, ...)."""
    yield value
    if isinstance(value, dict):
        children: Iterable[Any] = [*value.keys(), *value.values()]
    elif isinstance(value, (list, tuple, set, frozenset)):
        children = value
    else:
        return
    for child in children:
        yield child
        if isinstance(child, (list, tuple)):
            yield from child


def _is_substitute(value: Any) -> bool:
    return isinstance(value, type) and issubclass(value, ReinforceInPlaceOf)


def _is_off_policy(value: Any) -> bool:
    return isinstance(value, type) and issubclass(value, OffPolicyAlgorithm)


def _globals_read(code: types.CodeType) -> set[str]:
    """
    The global names a function's code (with its nested functions, lambdas and comprehensions) reads. A name
    imported inside the function is local: ``from stable_baselines3 import A2C`` there gives SB3's own A2C.
    """
    names = {ins.argval for ins in dis.get_instructions(code) if ins.opname in ("LOAD_GLOBAL", "LOAD_NAME")}
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _globals_read(const)
    return names


def exercises_on_policy(item: pytest.Function, module: types.ModuleType) -> bool:
    """
    Whether SB3's test ``item`` runs an on-policy algorithm, so REINFORCE in its place: a parameter is A2C or PPO
    (or names them, as the keys of test_tensorboard's ``MODEL_DICT``) and none is an off-policy algorithm, or,
    without such parameters, the test's code or one of its module's fixtures uses A2C or PPO (directly, or through a
    module-level list or dict).
    """
    params = item.callspec.params.values() if hasattr(item, "callspec") else []
    resolved = []
    for value in params:
        resolved.append(value)
        if isinstance(value, str):  # a key of a module-level dict, e.g. MODEL_DICT["a2c"] = (A2C, "CartPole-v1")
            tables = [table for name, table in vars(module).items() if not name.startswith("__") and isinstance(table, dict)]
            resolved += [table[value] for table in tables if value in table]
    members = [member for value in resolved for member in _members(value)]
    if any(_is_off_policy(member) for member in members):
        return False
    if any(_is_substitute(member) for member in members):
        return True
    names = _globals_read(item.function.__code__)
    # and those of its fixtures defined in its module (test_distributions.py's fixture builds an A2C model)
    fixture_info = getattr(item, "_fixtureinfo", None)
    for definitions in fixture_info.name2fixturedefs.values() if fixture_info is not None else []:
        for definition in definitions:
            if getattr(definition.func, "__module__", None) == module.__name__:
                names |= _globals_read(definition.func.__code__)
    used = [vars(module)[name] for name in names if name in vars(module)]
    return any(_is_substitute(member) for value in used for member in _members(value))


# --- the collectors ---------------------------------------------------------------------------------------
def _assertion_rewriter() -> Any:
    """pytest's assertion-rewriting import hook (None with --assert=plain), to load SB3's modules with it."""
    from _pytest.assertion.rewrite import AssertionRewritingHook

    return next((finder for finder in sys.meta_path if isinstance(finder, AssertionRewritingHook)), None)


def import_with_substitutes(path: pathlib.Path, module_name: str, substitutes: dict[str, type]) -> types.ModuleType:
    """
    Import SB3's test module ``path`` as ``module_name``, with ``from stable_baselines3 import A2C, PPO``
    giving ``substitutes``. What the module defines is pickled by value (cloudpickle), so that SubprocVecEnv's
    workers need not import it.
    """
    spec = importlib.util.spec_from_file_location(module_name, path, loader=_assertion_rewriter())
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    try:
        with mock.patch.multiple(stable_baselines3, **substitutes):
            spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[module_name]
        raise
    cloudpickle.register_pickle_by_value(module)
    return module


class SB3TestModule(pytest.Module):
    """One of SB3's test files, imported for one variant, holding only its tests that exercise A2C/PPO."""

    variant: str

    def _getobj(self) -> types.ModuleType:
        module_name = f"sb3_tests_{self.variant.replace('-', '_')}__{self.path.stem}"
        return import_with_substitutes(self.path, module_name, make_substitutes(VARIANTS[self.variant]))

    def collect(self) -> list[pytest.Item | pytest.Collector]:
        differences: list[Difference] = self.config.stash.get(differences_key, [])
        ids = self.config.stash.setdefault(collected_ids, {}).setdefault(self.variant, set())
        kept: list[pytest.Item | pytest.Collector] = []
        for node in super().collect():
            if not isinstance(node, pytest.Function) or not exercises_on_policy(node, self.obj):
                continue  # SB3's own unit tests, and the tests of off-policy algorithms: not REINFORCE's to pass
            test_id = f"{self.name}::{node.name}"
            ids.add(test_id)
            for difference in differences:
                if difference.matches(test_id, self.variant):
                    if difference.outcome == "xfail":
                        node.add_marker(pytest.mark.xfail(strict=True, reason=difference.reason))
                    elif difference.outcome == "rerun":
                        node.add_marker(
                            pytest.mark.flaky(reruns=RERUNS, reruns_delay=RERUNS_DELAY_S, only_rerun=["AssertionError"])
                        )
                        node.add_marker(pytest.mark.alone)  # no other test beside it (tests/alone.py)
                    else:
                        node.add_marker(pytest.mark.skip(reason=f"not run: {difference.reason}"))
                    break
            kept.append(node)
        return kept


class SB3Variant(pytest.Collector):
    """SB3's test files, run with REINFORCE's ``baseline`` of one variant."""

    tests_dir: pathlib.Path

    def collect(self) -> list[pytest.Item | pytest.Collector]:
        modules: list[pytest.Item | pytest.Collector] = []
        for file_name in read_test_files():
            module = SB3TestModule.from_parent(
                self, path=self.tests_dir / file_name, name=file_name, nodeid=f"{self.nodeid}::{file_name}"
            )
            module.variant = self.name
            modules.append(module)
        return modules


class SB3TestsMissing(pytest.Item):
    """Stands for the suite when SB3's tests cannot be fetched: skipped, or failed under CI."""

    reason: str

    def runtest(self) -> None:
        message = f"SB3's tests could not be fetched, none of them ran: {self.reason}"
        if running_in_ci():
            pytest.fail(message + " (CI=true: a suite that did not run is not a pass)", pytrace=False)
        pytest.skip(message)

    def reportinfo(self) -> tuple[pathlib.Path, int, str]:
        return self.path, 0, f"SB3 {installed_sb3_version()} tests"


class SB3Suite(pytest.File):
    """The root of the suite: ``sb3_test_files.txt``, the list of SB3's test files to run."""

    def collect(self) -> list[pytest.Item | pytest.Collector]:
        self.config.stash[differences_key] = read_differences()
        try:
            tests_dir = sb3_tests_dir()
        except SB3TestsUnavailable as error:
            missing = SB3TestsMissing.from_parent(self, name="sb3_tests_available")
            missing.reason = str(error)
            return [missing]
        variants: list[pytest.Item | pytest.Collector] = []
        for name in VARIANTS:
            variant = SB3Variant.from_parent(self, name=name)
            variant.tests_dir = tests_dir
            variants.append(variant)
        return variants
