"""The runner of SB3's tests: what it collects, how it translates arguments, and what it does without the sdist."""

import os
import pathlib
import subprocess
import sys

import pytest
from stable_baselines3.common.env_util import make_vec_env

from tests.sb3_suite.substitutes import DEFAULT_SEED, DROPPED_ARGUMENTS, make_substitutes, translate_arguments
from tests.sb3_suite.suite import RERUNS, RERUNS_DELAY_S, TEST_FILES_LIST, VARIANTS, collected_ids, read_differences

REPOSITORY = pathlib.Path(__file__).parents[2]


def suite_ids(config: pytest.Config) -> dict[str, set[str]]:
    """The SB3 test ids collected in this session, per variant (skip when the suite was not collected)."""
    ids = config.stash.get(collected_ids, {})
    if set(ids) != set(VARIANTS) or not all(ids.values()):
        pytest.skip("SB3's tests were not collected in this session (run the whole tests/sb3_suite folder)")
    return ids


def test_every_difference_matches_a_collected_test(request: pytest.FixtureRequest) -> None:
    """A row of differences.md that matches no test is stale (the test was renamed or removed from SB3)."""
    ids = suite_ids(request.config)
    stale = [
        f"{difference.pattern} ({', '.join(difference.variants)})"
        for difference in read_differences()
        if not all(any(difference.matches(test_id, variant) for test_id in ids[variant]) for variant in difference.variants)
    ]
    assert not stale, f"differences.md rows that match no collected SB3 test: {stale}"


def test_rerun_rows_mark_their_tests_flaky(request: pytest.FixtureRequest) -> None:
    """A ``rerun`` row gives its tests pytest-rerunfailures' marker (on a failed assertion) and ``alone``; others neither."""
    ids = suite_ids(request.config)
    rerun_rows = [difference for difference in read_differences() if difference.outcome == "rerun"]
    rerun = {
        (variant, test_id)
        for variant, variant_ids in ids.items()
        for test_id in variant_ids
        if any(row.matches(test_id, variant) for row in rerun_rows)
    }
    assert len(rerun) == 2, "test_logger.py::test_fps_logger[REINFORCE_as_A2C], in both variants"
    selected = 0
    for item in request.session.items:
        if "sb3_test_files.txt::" not in item.nodeid:
            continue
        variant, test_id = item.nodeid.split("::", 2)[1:]
        marker = item.get_closest_marker("flaky")
        if (variant, test_id) in rerun:
            assert marker is not None, item.nodeid
            assert marker.kwargs == dict(reruns=RERUNS, reruns_delay=RERUNS_DELAY_S, only_rerun=["AssertionError"])
            assert item.get_closest_marker("alone") is not None, item.nodeid
            selected += 1
        else:
            assert marker is None and item.get_closest_marker("alone") is None, item.nodeid
    if not selected:
        pytest.skip("the tests of the rerun rows are not selected in this session")


def test_only_on_policy_tests_are_collected(request: pytest.FixtureRequest) -> None:
    ids = suite_ids(request.config)
    for variant_ids in ids.values():
        assert "test_run.py::test_a2c[CartPole-v1]" in variant_ids
        assert "test_cnn.py::test_cnn[False-REINFORCE_as_A2C]" in variant_ids  # parametrized: on-policy ones kept
        assert "test_tensorboard.py::test_tensorboard[a2c]" in variant_ids  # through MODEL_DICT["a2c"]
        assert "test_distributions.py::test_get_distribution" in variant_ids  # through its fixture
        for off_policy in (
            "test_run.py::test_dqn",
            "test_run.py::test_sac[auto]",
            "test_tensorboard.py::test_tensorboard[sac]",
        ):
            assert off_policy not in variant_ids
        assert not any(name in test_id for test_id in variant_ids for name in ("DQN", "SAC", "TD3", "DDPG"))
        # SB3's unit tests that run no algorithm
        assert not any(test_id.startswith("test_sde.py::test_state_dependent_exploration_grad") for test_id in variant_ids)
        assert not any(test_id.startswith("test_vec_normalize.py::") for test_id in variant_ids)
    assert ids["no-baseline"] == ids["value-baseline"]


def test_arguments_are_translated() -> None:
    given = dict(
        n_steps=64, normalize_advantage=False, learning_rate=3e-4, ent_coef=0.01, **dict.fromkeys(DROPPED_ARGUMENTS, 1)
    )
    translated, n_steps = translate_arguments(given)
    assert n_steps == 64
    assert translated == dict(normalize_returns=False, learning_rate=3e-4, ent_coef=0.01)


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_substitutes(variant: str) -> None:
    baseline = VARIANTS[variant]
    substitutes = make_substitutes(baseline)
    env = make_vec_env("CartPole-v1", n_envs=2)
    model = substitutes["PPO"]("MlpPolicy", env, n_steps=64, n_epochs=4, batch_size=32, clip_range=0.1, gae_lambda=0.9)
    assert model.min_steps == 64 * 2, "n_steps counts per environment"
    assert model.baseline == baseline and model.seed == DEFAULT_SEED
    assert hasattr(model.policy, "value_net") == (baseline == "value")
    # A baseline given by the test is kept; arguments REINFORCE knows pass through; unknown ones raise as for users
    assert substitutes["A2C"]("MlpPolicy", env, baseline="loo", seed=3).baseline == "loo"
    with pytest.raises(TypeError, match="no_such_argument"):
        substitutes["A2C"]("MlpPolicy", env, no_such_argument=1)


def test_tensorboard_folder_is_named_after_the_replaced_algorithm(tmp_path: pathlib.Path) -> None:
    model = make_substitutes(None)["A2C"]("MlpPolicy", "CartPole-v1", tensorboard_log=str(tmp_path))
    model.learn(10)
    model.learn(10, tb_log_name="mine")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["A2C_1", "mine_1"]


def test_differences_are_well_formed() -> None:
    differences = read_differences()
    assert differences
    patterns = [(difference.pattern, difference.variants) for difference in differences]
    assert len(patterns) == len(set(patterns)), "a row is repeated"
    listed = (pathlib.Path(TEST_FILES_LIST).read_text()).split()
    for difference in differences:
        assert difference.pattern.split("::")[0] in listed, f"{difference.pattern}: not a file of sb3_test_files.txt"
        assert len(difference.reason) > 40, f"{difference.pattern}: say why REINFORCE legitimately differs"


@pytest.mark.parametrize("ci", ["true", ""])
def test_missing_sdist_skips_or_fails_under_ci(tmp_path: pathlib.Path, ci: str) -> None:
    """Without the sdist (here: an empty cache and no package index) the suite is skipped, but fails under CI=true."""
    env = {**os.environ, "SB3_REINFORCE_CACHE_DIR": str(tmp_path), "PIP_NO_INDEX": "1", "CI": ci}
    command = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:xdist", "-q", "-rsf", str(TEST_FILES_LIST)]
    result = subprocess.run(command, cwd=REPOSITORY, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert "SB3's tests could not be fetched, none of them ran" in result.stdout, result.stdout
    if ci:
        assert result.returncode == 1 and "1 failed" in result.stdout and "CI=true" in result.stdout
    else:
        assert result.returncode == 0 and "1 skipped" in result.stdout
