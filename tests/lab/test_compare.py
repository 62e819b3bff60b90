"""The comparison command, its statistics and its bad-input errors."""

import argparse
import contextlib
import json
import os
import re
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest
import torch as th
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure
from scipy import stats

import sb3_reinforce
from sb3_reinforce.lab import provenance
from sb3_reinforce.lab.cli import main as cli_main
from sb3_reinforce.lab.compare import experiment, runner
from sb3_reinforce.lab.compare.command import build_parser, main, parse_specs, runs_to_do, write_outputs
from sb3_reinforce.lab.compare.experiment import EVAL_SEED_OFFSET, build_run, known_algos, read_entry
from sb3_reinforce.lab.compare.figures import (
    BAND_LABEL,
    best_mean,
    every_seed_reached,
    overview_table,
    plot_learning_curves,
    plot_seed_curves,
    published_table,
    seed_table,
    summary_table,
    to_markdown,
)
from sb3_reinforce.lab.compare.folder import PER_RUN_DIR, RESULT_COLUMNS, ComparisonFolder, RunSpec
from sb3_reinforce.lab.report import build_parser as build_report_parser
from sb3_reinforce.lab.report import main as render_main
from sb3_reinforce.lab.report import require_markers, update_readme
from sb3_reinforce.lab.seed.reproduction import EPISODE_COLUMNS, RewardFloor
from sb3_reinforce.lab.seed.reproduction import build_parser as build_seed_parser
from sb3_reinforce.lab.seed.reproduction import main as seed_main
from sb3_reinforce.lab.stats import (
    THRESHOLDS_WITHOUT_GYMNASIUM,
    bootstrap_ci,
    first_crossing,
    iqm,
    quantile_with_inf,
    rolling_mean,
    solve_threshold,
)
from sb3_reinforce.version import __version__
from tests.lab.test_cluster import assert_localhost_only

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# ---------------------------------------------------------------- statistics, against hand-computed values


def test_iqm_hand_computed() -> None:
    assert iqm([1, 2, 3, 4, 5]) == 3.0  # drops 1 and 5: mean(2, 3, 4)
    assert iqm([5, 1, 100, 4, 2]) == pytest.approx(11 / 3)  # sorted 1 2 4 5 100: mean(2, 4, 5)
    assert iqm([1, 2, 3, 10]) == 2.5  # mean(2, 3)
    assert iqm([1, 2, 3, 4, 5, 6, 7, 8]) == 4.5  # mean(3, 4, 5, 6)
    with pytest.raises(ValueError):
        iqm([])


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=40))
def test_iqm_is_scipys_trim_mean(values: list[float]) -> None:
    # The same float as scipy's (rliable's IQM), NaN where scipy gives NaN
    expected = stats.trim_mean(np.asarray(values), 0.25, axis=None)
    with np.errstate(all="ignore"):
        got = iqm(values)
    assert got == expected or (np.isnan(got) and np.isnan(expected))


_ROW_VALUE = st.floats(allow_nan=True, allow_infinity=False, width=64)


@given(st.integers(1, 12).flatmap(lambda n: st.lists(st.lists(_ROW_VALUE, min_size=n, max_size=n), min_size=1, max_size=6)))
@settings(deadline=None)  # the unvectorized bootstrap calls iqm once per resample: ~0.2 s on a loaded 2-core machine
def test_iqm_along_an_axis_is_each_rows_iqm(rows: list[list[float]]) -> None:
    # What scipy's bootstrap passes a statistic that takes `axis`: every resample at once, one IQM per row
    array = np.asarray(rows)
    with np.errstate(all="ignore"):
        got = iqm(array, axis=1)
        expected = [iqm(row) for row in rows]
    np.testing.assert_array_equal(got, expected)
    # vectorized or called once per resample: the same interval (NaN where a value is)
    one_at_a_time = bootstrap_ci(array[0], lambda x: iqm(x), n_resamples=200)
    np.testing.assert_array_equal(bootstrap_ci(array[0], iqm, n_resamples=200), one_at_a_time)


def test_bootstrap_ci_hand_computed() -> None:
    # Resampled means of [0, 1]: 0 (p=1/4), 0.5 (p=1/2), 1 (p=1/4): the 5% and 95% quantiles are 0 and 1.
    assert bootstrap_ci([0.0, 1.0], np.mean, confidence=0.9) == (0.0, 1.0)
    # A constant sample has a zero-width interval, whatever the statistic.
    assert bootstrap_ci([7.0] * 5, iqm) == (7.0, 7.0)
    # Each resample mean lies in [min, max]; the interval is reproducible and contains the sample mean here.
    values = [1.0, 2.0, 3.0, 4.0, 10.0]
    low, high = bootstrap_ci(values)
    assert 1.0 <= low < np.mean(values) < high <= 10.0
    assert bootstrap_ci(values) == (low, high)
    # A narrower confidence gives a narrower interval
    low50, high50 = bootstrap_ci(values, confidence=0.5)
    assert low <= low50 and high50 <= high
    with pytest.raises(ValueError):
        bootstrap_ci(values, confidence=1.0)
    # One run: every resample is its value (scipy's bootstrap refuses a single observation)
    assert bootstrap_ci([3.0], iqm) == (3.0, 3.0)


def test_solve_thresholds_are_gymnasiums() -> None:
    # Gymnasium's reward_threshold where the env has one; Pendulum-v1 has none and takes issue #13's -200
    expected = {"CartPole-v1": 475, "Acrobot-v1": -100, "LunarLander-v3": 200, "MountainCar-v0": -110, "CarRacing-v3": 900}
    assert {env_id: solve_threshold(env_id) for env_id in expected} == expected
    assert gym.spec("Pendulum-v1").reward_threshold is None and solve_threshold("Pendulum-v1") == -200
    assert solve_threshold("Pendulum-v1") == THRESHOLDS_WITHOUT_GYMNASIUM["Pendulum-v1"]
    assert solve_threshold("NoSuchEnv-v0") is None


def test_first_crossing_hand_computed() -> None:
    steps, scores = [0, 10, 20, 30], [1.0, 5.0, 3.0, 9.0]
    assert first_crossing(steps, scores, 5.0) == 10  # reaching counts (>=), the first time
    assert first_crossing(steps, scores, 6.0) == 30
    assert first_crossing(steps, scores, 0.0) == 0
    assert first_crossing(steps, scores, 10.0) == float("inf")  # not reached
    assert first_crossing(steps, [-150.0, -99.0, -100.0, -80.0], -100.0) == 10  # negative thresholds (Acrobot)
    with pytest.raises(ValueError):
        first_crossing([0, 1], [1.0], 0.0)


def test_quantile_with_inf_hand_computed() -> None:
    inf = float("inf")
    assert [quantile_with_inf([5, 1, 4, 2, 3], q) for q in (0.25, 0.5, 0.75)] == [2, 3, 4]
    assert quantile_with_inf([1, 2, 3, 4], 0.5) == 2.5
    assert quantile_with_inf([10, 20, 30, inf, inf], 0.5) == 30  # 3 of 5 reached: the median is finite
    assert quantile_with_inf([10, 20, 30, inf, inf], 0.75) == inf
    assert quantile_with_inf([10, 20, inf, inf, inf], 0.5) == inf  # most seeds did not reach it
    assert quantile_with_inf([10, 20, inf, inf], 0.5) == inf  # halfway between 20 and "never"
    assert quantile_with_inf([10, 20, inf, inf], 0.25) == 17.5


def test_rolling_mean_hand_computed() -> None:
    np.testing.assert_allclose(rolling_mean([1, 2, 3, 4], 2), [1.0, 1.5, 2.5, 3.5])
    np.testing.assert_allclose(rolling_mean([4, 0, 2], 10), [4.0, 2.0, 2.0])


# ---------------------------------------------------------------- hyperparameters


def test_zoo_entries_read_as_the_zoo_reads_them() -> None:
    ppo = read_entry("ppo", "CartPole-v1")
    assert ppo.source.parts[-3:] == ("rl_zoo3", "hyperparams", "ppo.yml")  # the installed zoo's file
    assert (ppo.n_envs, ppo.n_timesteps) == (8, 100_000)
    assert ppo.hyperparams["learning_rate"] == "lin_0.001"  # as written in the file
    reinforce = read_entry("reinforce", "CartPole-v1")
    assert reinforce.source.name == "reinforce.yml" and reinforce.hyperparams["policy"] == "MlpPolicy"
    assert {"reinforce", "ppo", "a2c", "trpo"} <= set(known_algos())


@pytest.mark.parametrize("config", sorted(Path(__file__).parents[2].glob("benchmarks/configs/*.yml")), ids=lambda p: p.name)
def test_benchmark_configs_load_and_build(config: Path, tmp_path: Path) -> None:
    # The committed benchmark configs are read again by every run of a resumed comparison: each entry must
    # parse and build its model through the zoo.
    import yaml

    env_ids = list(yaml.load(config.read_text(), Loader=yaml.UnsafeLoader))
    assert env_ids
    for env_id in env_ids:
        built = build_run("reinforce", env_id, 0, 1000, tmp_path, config)
        assert built.model.n_envs == built.entry.n_envs


def test_malformed_config_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "r.yml"
    path.write_text("Acrobot-v1: 1e6, where: x). oops\n  n_envs: 1\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        read_entry("reinforce", "Acrobot-v1", path)
    path.write_text("Acrobot-v1:\n  n_timesteps: 10\n  policy: MlpPolicy\n  n_steps: 5\n")
    with pytest.raises(ValueError, match="does not accept 'n_steps'"):
        read_entry("reinforce", "Acrobot-v1", path)
    with pytest.raises(ValueError, match="no entry for CartPole-v1"):
        read_entry("reinforce", "CartPole-v1", path)


def _wrappers(env: object) -> list[str]:
    """The class names of a VecEnv's wrapper stack, then of its first environment's."""
    names = []
    while hasattr(env, "venv"):
        names.append(type(env).__name__)
        env = env.venv  # type: ignore[attr-defined]
    names.append(type(env).__name__)
    inner = env.envs[0]  # type: ignore[attr-defined]
    while hasattr(inner, "env"):
        names.append(type(inner).__name__)
        inner = inner.env
    return [*names, type(inner).__name__]


def test_compare_builds_the_agent_zoo_train_builds(tmp_path: Path) -> None:
    # The same entry and seed through `sb3-reinforce-zoo train` and through compare's build: the same
    # hyperparameters, wrapper stack, first actions, and weights after a few updates (Pendulum-v1: normalization,
    # 8 envs, gSDE, value steps, policy_kwargs; REINFORCE makes one update per 8 episodes of 200 steps).
    import torch as th
    import yaml

    from sb3_reinforce import REINFORCE
    from sb3_reinforce.lab.zoo import main as zoo_main

    budget, seed = 3400, 5
    args = ["train", "--algo", "reinforce", "--env", "Pendulum-v1", "-n", str(budget), "--seed", str(seed)]
    assert zoo_main([*args, "--eval-freq", "-1", "--verbose", "0", "-f", str(tmp_path / "zoo"), "--num-threads", "1"]) == 0
    run_dir = tmp_path / "zoo" / "reinforce" / "Pendulum-v1_1"
    from_zoo = REINFORCE.load(run_dir / "Pendulum-v1.zip", device="cpu")

    threads = th.get_num_threads()
    th.set_num_threads(1)  # as the zoo run (--num-threads 1) and compare's runs: the same float sums
    try:
        built = build_run("reinforce", "Pendulum-v1", seed, budget, tmp_path / "compare")
        # (no reset before learn: a VecNormalize reset updates its statistics)
        built.model.learn(budget, callback=built.callbacks)
    finally:
        th.set_num_threads(threads)
    saved = yaml.load((run_dir / "Pendulum-v1" / "config.yml").read_text(), Loader=yaml.UnsafeLoader)
    assert dict(saved) == dict(built.entry.hyperparams)
    wrappers = _wrappers(built.train_env)
    assert wrappers[:3] == ["VecNormalize", "DummyVecEnv", "Monitor"] and "TimeLimit" in wrappers[3]  # rl_zoo3's own
    assert wrappers[-1] == "PendulumEnv"
    assert _wrappers(built.eval_env)[:2] == ["VecNormalize", "DummyVecEnv"] and not built.eval_env.training

    assert built.model._n_updates == from_zoo._n_updates >= 2
    for key, value in from_zoo.policy.state_dict().items():
        th.testing.assert_close(built.model.policy.state_dict()[key], value, rtol=0, atol=0)
    # and the same agent acts the same: the first actions after training, on the same observations
    obs = np.stack([built.train_env.observation_space.sample() for _ in range(16)])
    np.testing.assert_array_equal(
        built.model.predict(obs, deterministic=True)[0], from_zoo.predict(obs, deterministic=True)[0]
    )


def test_tiny_compare_on_car_racing(tmp_path: Path) -> None:
    # The shipped CarRacing-v3 entry's image wrappers (frame skip, resize, grayscale), frame stack, reward
    # normalization and CNN policy, on 2 envs whose episodes are cut at 40 frames (env_kwargs) to keep it short;
    # the evaluation runs on the standard env (1,000 frames an episode).
    import yaml

    shipped = yaml.load((Path(__file__).parents[2] / "zoo_configs" / "reinforce.yml").read_text(), Loader=yaml.UnsafeLoader)
    entry = {**shipped["CarRacing-v3"], "n_envs": 2, "env_kwargs": {"max_episode_steps": 40}}
    config = tmp_path / "car_racing.yml"
    config.write_text(yaml.dump({"CarRacing-v3": entry}))
    out = tmp_path / "cmp"
    args = ["--env", "CarRacing-v3", "--algos", "reinforce", "--seeds", "1", "--budget", "1", "--eval-freq", "1000"]
    args += ["--eval-episodes", "1"]
    main([*args, "--reinforce-config", str(config), "--workers", "1", "--no-progress", "--out", str(out)])
    results = pd.read_csv(out / "results.csv")
    assert len(results) == 2 and results["steps"].iloc[-1] == 2 * 20  # one batch: 2 episodes of 40 frames, skip 2
    built = build_run("reinforce", "CarRacing-v3", 0, 1, tmp_path / "zoo", config)
    assert built.train_env.observation_space.shape == (2, 64, 64)  # 2 grayscale 64x64 frames, channel first
    assert _wrappers(built.train_env)[:3] == ["VecTransposeImage", "VecFrameStack", "VecNormalize"]
    assert {"GrayscaleObservation", "FrameSkip"} <= set(_wrappers(built.train_env))
    assert built.eval_env.observation_space.shape == (2, 64, 64)


@pytest.mark.parametrize(("cores", "n_workers"), [(2, 1), (4, 2)])
def test_default_workers_keep_subproc_runs_within_the_cores(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cores: int, n_workers: int
) -> None:
    # Without --workers, as many runs go at once as the cores hold: a --vec-env subproc run of 2 envs keeps 2 busy
    monkeypatch.setattr(os, "cpu_count", lambda: cores)
    config = tmp_path / "r.yml"
    config.write_text("CartPole-v1:\n  n_envs: 2\n  n_timesteps: 1000\n  policy: MlpPolicy\n")
    out = tmp_path / "cmp"
    args = ["--env", "CartPole-v1", "--algos", "reinforce", "--seeds", "2", "--budget", "1", "--eval-freq", "1000"]
    args += ["--eval-episodes", "1", "--vec-env", "subproc", "--reinforce-config", str(config)]
    main([*args, "--no-progress", "--out", str(out)])
    workers = {json.loads(path.read_text())["worker"] for path in (out / PER_RUN_DIR).glob("*.json")}
    assert len(workers) == n_workers, workers


def test_tiny_compare_with_env_kwargs(tmp_path: Path) -> None:
    # Training with a longer time limit (env_kwargs), evaluation on the standard 200-step env, as the zoo does
    config = tmp_path / "r.yml"
    config.write_text(
        "MountainCar-v0:\n  n_envs: 2\n  n_timesteps: 1000\n  policy: MlpPolicy\n  env_kwargs: {max_episode_steps: 500}\n"
    )
    out = tmp_path / "cmp"
    args = ["--env", "MountainCar-v0", "--algos", "reinforce", "--seeds", "1", "--budget", "1", "--eval-freq", "1000"]
    args += ["--eval-episodes", "1"]
    main([*args, "--reinforce-config", str(config), "--workers", "1", "--no-progress", "--out", str(out)])
    results = pd.read_csv(out / "results.csv")
    assert results["steps"].iloc[-1] >= 2 * 500  # two training episodes of 500 steps (a random policy rarely ends sooner)
    assert (results["mean_return"] == -200).all()  # evaluation episodes end at the standard 200 steps
    built = build_run("reinforce", "MountainCar-v0", 0, 1, tmp_path / "zoo", config)
    assert built.train_env.envs[0].spec.max_episode_steps == 500  # type: ignore[attr-defined]
    assert built.eval_env.envs[0].spec.max_episode_steps == 200  # type: ignore[attr-defined]
    assert EVAL_SEED_OFFSET == 10_000


# ---------------------------------------------------------------- bad input: clear errors before training

#: A REINFORCE file with one entry and no `default` one (zoo_configs/reinforce.yml has a default entry)
ACROBOT_ONLY = str(Path(__file__).parents[2] / "benchmarks" / "configs" / "reinforce_acrobot_value20.yml")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--env", "NoSuchEnv-v0"], "Unknown environment 'NoSuchEnv-v0'"),
        (["--algos", "reinforce,nosuchalgo"], "Unknown algorithm"),
        (["--seeds", "0"], "--seeds must be >= 1"),
        (["--first-seed", "-1"], "--first-seed must be from 0 to 2,147,483,645"),
        (["--seeds", "2", "--first-seed", str(2**31 - 1)], "--first-seed must be from 0 to 2,147,483,646"),
        (["--workers", "0"], "--workers must be >= 1, got 0"),
        (["--eval-freq", "0"], "--eval-freq must be >= 1"),
        (["--threshold", "high"], "--threshold must be a number"),
        (["--budget", "lots"], "--budget must be"),
        (["--device", "gpu"], "device must be cpu, cuda, cuda:N, mps or auto (a PyTorch device), got 'gpu'"),
        (["--device", "xla"], "device must be cpu, cuda, cuda:N, mps or auto"),
        (["--device", "cuda:99"], "device 'cuda:99': PyTorch"),  # a GPU this machine lacks, whatever it has
        (
            ["--env", "MountainCarContinuous-v0", "--algos", "reinforce", "--reinforce-config", ACROBOT_ONLY],
            "has no entry for MountainCarContinuous-v0 (it has: Acrobot-v1)",  # a file without a default entry
        ),
        (
            ["--env", "MountainCarContinuous-v0", "--algos", "reinforce", "--reinforce-config", ACROBOT_ONLY],
            "Add one, or pass another file with --config reinforce=FILE.",  # compare's flag, not the zoo's -conf
        ),
        (["--env", "CliffWalking-v1", "--stop-at-threshold"], "--stop-at-threshold needs a threshold: CliffWalking-v1"),
        (["--config", "ppo"], "--config takes ALGO=FILE with ALGO among"),
        (["--config", "nosuchalgo=x.yml"], "--config takes ALGO=FILE with ALGO among"),
        (["--config", "ppo=a.yml", "PPO=b.yml"], "--config names ppo twice"),
        (["--config", f"reinforce={ACROBOT_ONLY}", "--reinforce-config", ACROBOT_ONLY], "the same option: give one"),
        (["--env", "Pendulum-v1", "--algos", "ppo", "--config", f"ppo={ACROBOT_ONLY}"], "--config ppo=FILE."),
    ],
)
def test_bad_input_fails_before_training(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main([*args, "--out", str(out), "--no-progress"])
    assert exc.value.code == 2
    before, error = capsys.readouterr().err.split("sb3-reinforce compare: error: ")
    assert before == "" and message in error and error.count("\n") == 1  # the one line, no usage, no traceback
    assert not out.exists()  # nothing was started


# the verification folders with a finished run (results.csv is written once a run has finished)
VERIFIED = sorted(p.parent for p in Path(__file__).resolve().parents[2].glob("benchmarks/results/verify_*/results.csv"))


@pytest.mark.parametrize("folder", VERIFIED, ids=str)
def test_printed_table_fits_a_terminal(folder: Path) -> None:
    # compare prints summary.md's figures in about 110 columns (summary.md keeps the IQRs: 200+)
    threshold = json.loads((folder / "comparison.json").read_text())["threshold"]
    results, summaries = pd.read_csv(folder / "results.csv"), ComparisonFolder(folder).load_summaries()
    printed = summary_table(results, summaries, threshold, compact=True).to_string(index=False)
    assert max(len(line) for line in printed.splitlines()) <= 120
    assert max(len(line) for line in to_markdown(summary_table(results, summaries, threshold)).splitlines()) > 120


def test_budget_options() -> None:
    parser = build_parser()
    specs, threshold, _ = parse_specs(parser.parse_args([]))
    assert threshold == 475.0
    assert {s.algo: s.budget for s in specs} == {"reinforce": 100_000, "ppo": 100_000, "a2c": 100_000}  # PPO's budget
    assert {s.eval_freq for s in specs} == {5_000} and len(specs) == 9
    specs, _, _ = parse_specs(parser.parse_args(["--budget", "zoo", "--threshold", "400"]))
    assert {s.algo: s.budget for s in specs} == {"reinforce": 100_000, "ppo": 100_000, "a2c": 500_000}
    specs, _, _ = parse_specs(parser.parse_args(["--budget", "2e4", "--algos", "ppo", "--seeds", "2", "--first-seed", "7"]))
    assert [(s.algo, s.seed, s.budget) for s in specs] == [("ppo", 7, 20_000), ("ppo", 8, 20_000)]


def test_the_plan_names_a_fallback_entry(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # rl_zoo3 trains an env its file has no entry for with the file's `default` entry: A2C on CarRacing-v3 would
    # be an MLP on the raw pixels, one env. The entry says so, and so does the plan compare prints.
    _, _, entries = parse_specs(build_parser().parse_args(["--env", "CarRacing-v3", "--algos", "reinforce,a2c"]))
    assert entries["a2c"].fallback == "default" and entries["a2c"].hyperparams["policy"] == "MlpPolicy"
    assert entries["reinforce"].fallback is None and entries["reinforce"].hyperparams["policy"] == "CnnPolicy"
    args = ["--env", "FrozenLake-v1", "--algos", "a2c", "--seeds", "1", "--budget", "50", "--eval-freq", "50"]
    main([*args, "--eval-episodes", "1", "--workers", "1", "--no-progress", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert "a2c.yml has no entry for FrozenLake-v1: its 'default' entry is used (MlpPolicy, 1 env(s))" in out
    assert (tmp_path / "results.csv").exists()


def test_stop_at_threshold_ends_each_run_at_its_first_evaluation_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Issue 64's wall-clock benchmark: the training seconds to the threshold, without the rest of the budget
    threshold = 100.0  # above the untrained policy's score, reached by REINFORCE within the budget
    args = ["--env", "CartPole-v1", "--algos", "reinforce", "--seeds", "1", "--budget", "20000", "--eval-freq", "500"]
    args += ["--eval-episodes", "2", "--threshold", str(threshold), "--workers", "1", "--no-progress"]
    main([*args, "--stop-at-threshold", "--out", str(tmp_path)])
    assert "ending at the first deterministic evaluation >= 100" in capsys.readouterr().out
    evaluations = pd.read_csv(tmp_path / PER_RUN_DIR / "reinforce_seed0.csv")
    reached = evaluations["mean_return"] >= threshold
    assert reached.iloc[-1] and not reached.iloc[:-1].any() and len(evaluations) > 1
    summary = json.loads((tmp_path / PER_RUN_DIR / "reinforce_seed0.json").read_text())
    assert summary["steps"] == evaluations["steps"].iloc[-1] < 20_000 and summary["spec"]["stop_at"] == threshold
    assert len(summary["load_1min"]) == 2
    assert not list((tmp_path / PER_RUN_DIR).glob("*.checkpoint*"))
    # without it, a run's identity is what the runs made before the option recorded (no stop_at key)
    assert "stop_at" not in RunSpec("CartPole-v1", "reinforce", 0, 1000, 500, 2).identity()


def test_a_users_own_env_runs_on_the_algorithms_defaults(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 62: --gym-packages imports the module that registers the user's env, here and in the runs' worker
    # processes; no zoo file has an entry for it, so each algorithm trains with its file's default entry (REINFORCE's
    # and PPO's constructor defaults), and the plan and the tables say so
    out = tmp_path / "out"
    args = ["--env", "Reach1D-v0", "--gym-packages", "tests.user_env", "--algos", "reinforce,ppo", "--seeds", "1"]
    args += ["--budget", "2048", "--eval-freq", "1024", "--eval-episodes", "2", "--workers", "1", "--no-progress"]
    main([*args, "--out", str(out)])
    printed = capsys.readouterr().out
    assert "reinforce.yml has no entry for Reach1D-v0: its 'default' entry is used (MlpPolicy, 1 env(s))" in printed
    assert "ppo.yml has no entry for Reach1D-v0: its 'default' entry is used (MlpPolicy, 1 env(s))" in printed
    assert "REINFORCE (defaults)" in printed and "PPO (defaults)" in printed  # the terminal's table
    table = (out / "summary.md").read_text()
    assert "| REINFORCE (defaults) | 1 |" in table and "| PPO (defaults) | 1 |" in table and "steps to -3" in table
    summary = json.loads((out / PER_RUN_DIR / "reinforce_seed0.json").read_text())
    assert summary["zoo_entry"] == "default" and summary["hyperparams"] == {"n_timesteps": "1000000.0", "policy": "MlpPolicy"}
    # the same env named as module:EnvName-v0, and a module that cannot be imported, named
    specs, _, _ = parse_specs(build_parser().parse_args(["--env", "tests.user_env:Reach1D-v0", "--algos", "reinforce"]))
    assert specs[0].entry is not None and specs[0].entry.fallback == "default"
    with pytest.raises(ValueError, match="--gym-packages: cannot import 'no_such_package'"):
        parse_specs(build_parser().parse_args(["--env", "Reach1D-v0", "--gym-packages", "no_such_package"]))


def test_any_zoo_algorithm_beside_reinforce(tmp_path: Path) -> None:
    # TRPO (sb3-contrib) with the installed zoo's entry, through the same path as REINFORCE, PPO and A2C
    specs, _, _ = parse_specs(build_parser().parse_args(["--algos", "reinforce,ppo,a2c,trpo", "--seeds", "1"]))
    assert [s.algo for s in specs] == ["reinforce", "ppo", "a2c", "trpo"] and {s.budget for s in specs} == {100_000}
    built = build_run("trpo", "CartPole-v1", 0, 1000, tmp_path)
    assert type(built.model).__name__ == "TRPO" and built.model.n_envs == built.entry.n_envs
    with pytest.raises(ValueError, match=r"choose among .*trpo"):
        parse_specs(build_parser().parse_args(["--algos", "reinforce,nosuchalgo"]))


def test_finished_run_with_other_settings_is_refused(tmp_path: Path) -> None:
    spec = RunSpec("CartPole-v1", "ppo", 0, 1000, 500, 2)
    (tmp_path / PER_RUN_DIR).mkdir()
    (tmp_path / PER_RUN_DIR / "ppo_seed0.csv").write_text(",".join(RESULT_COLUMNS) + "\n")  # interrupted: no JSON
    assert runs_to_do([spec], tmp_path) == [spec]
    other = RunSpec("CartPole-v1", "ppo", 0, 2000, 500, 2)
    (tmp_path / PER_RUN_DIR / "ppo_seed0.json").write_text(json.dumps({"spec": other.identity()}))
    with pytest.raises(ValueError, match="other settings"):
        runs_to_do([spec], tmp_path)
    assert runs_to_do([other], tmp_path) == []


# ---------------------------------------------------------------- a tiny comparison, end to end


def test_tiny_compare_run_resume_and_append(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cmp"
    common = ["--env", "CartPole-v1", "--seeds", "1", "--budget", "2000", "--eval-freq", "1000", "--eval-episodes", "2"]
    common += ["--workers", "1", "--no-progress", "--out", str(out)]
    main([*common, "--algos", "reinforce"])
    finished = out / PER_RUN_DIR / "reinforce_seed0.json"
    mtime = os.stat(finished).st_mtime_ns
    # An interrupted run of PPO: a CSV without a summary. It does not enter the results and is run again.
    (out / PER_RUN_DIR / "ppo_seed0.csv").write_text(",".join(RESULT_COLUMNS) + "\nCartPole-v1,ppo,0,0,0,0,0,1,0,1,0,1\n")
    write_outputs(out, "CartPole-v1", 475.0)
    assert set(pd.read_csv(out / "results.csv")["algo"]) == {"reinforce"}

    main([*common, "--algos", "reinforce,ppo"])  # appends PPO, skips the finished REINFORCE run
    assert f"2 runs of CartPole-v1 -> {out}: 1 already finished, 0 resume from a checkpoint, 1 start from scratch" in (
        capsys.readouterr().out
    )
    assert os.stat(finished).st_mtime_ns == mtime

    results = pd.read_csv(out / "results.csv")
    assert list(results.columns) == RESULT_COLUMNS
    assert list(results["algo"].unique()) == ["reinforce", "ppo"]
    for _, run in results.groupby("algo"):
        assert list(run["eval_index"]) == list(range(len(run)))
        assert run["steps"].iloc[0] == 0 and run["steps"].iloc[-1] >= 2000
        assert list(run["steps"]) == sorted(run["steps"]) and list(run["wall_time_s"]) == sorted(run["wall_time_s"])
        assert list(run["episodes"]) == sorted(run["episodes"]) and run["episodes"].iloc[-1] > 0
        assert run["mean_return"].between(1, 500).all() and run["mean_return_stochastic"].between(1, 500).all()
        assert (run["std_return"] >= 0).all() and (run["peak_rss_mb"] > 0).all()
        assert (run["std_return_stochastic"] > 0).any()  # the spread over episodes, not of a single mean
    summary = json.loads(finished.read_text())
    assert summary["steps_per_s"] > 0 and summary["cpu_time_s"] > 0
    assert summary["hyperparams_source"].endswith("reinforce.yml")
    assert summary["code_version"]["sb3_reinforce"] == __version__
    in_git = (Path(sb3_reinforce.__file__).parent.parent / ".git").exists()
    assert (summary["code_version"]["git_commit"] is not None) == in_git
    if in_git:
        assert len(summary["code_version"]["git_commit"]) == 40 and isinstance(summary["code_version"]["git_dirty"], bool)
    assert (out / "learning_curve.png").read_bytes()[:8] == PNG_MAGIC
    table = (out / "summary.md").read_text()
    assert "| REINFORCE | 1 |" in table and "| PPO | 1 |" in table and "steps to 475" in table


def test_each_run_records_its_system_and_the_report_names_differences(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A run's summary records what decides its numbers besides its settings (the versions, the CPU type, torch's
    # instruction set and threads); the report says when the runs it shows differ there, and is silent otherwise
    import shutil

    from sb3_reinforce.lab.report import system_differences

    first = tmp_path / "first"
    summary = runner.run(RunSpec("CartPole-v1", "reinforce", 0, 600, 300, 1), first)
    system = summary["system"]
    assert set(provenance.NUMERIC_KEYS) <= set(system)
    assert system["PyTorch"] == th.__version__ and system["Numpy"] == np.__version__ and system["PyTorch threads"] == "1"
    assert system["PyTorch CPU capability"] == th.backends.cpu.get_cpu_capability() and system["CPU"]
    assert system["sb3_reinforce"] == __version__
    (first / "comparison.json").write_text(json.dumps(dict(env="CartPole-v1", threshold=475.0)))
    second = tmp_path / "second"
    shutil.copytree(first, second)
    assert system_differences([first, second]) is None
    other = second / PER_RUN_DIR / "reinforce_seed0.json"
    recorded = json.loads(other.read_text())
    recorded["system"]["PyTorch"] = "2.9.1+cpu"
    other.write_text(json.dumps(recorded))
    note = system_differences([first, second])
    versions = ", ".join(sorted([str(th.__version__), "2.9.1+cpu"]))
    assert note is not None and f"PyTorch: {versions}" in note and "Numpy" not in note
    render_main([str(first), str(second)])
    assert note in capsys.readouterr().out
    del recorded["system"]  # a run made before systems were recorded is counted, not compared
    other.write_text(json.dumps(recorded))
    assert system_differences([first, second]) == (
        "Note: 1 of 2 runs recorded no system (made before it was recorded): whether they were made under the same "
        "versions and CPU type is unknown"
    )


def test_reinforce_config_is_read_only_with_reinforce(tmp_path: Path) -> None:
    # --reinforce-config (or --config ALGO=FILE) left on a command that compares other algorithms is not read
    args = ["--env", "CartPole-v1", "--algos", "ppo", "--seeds", "1", "--reinforce-config", str(tmp_path / "none.yml")]
    specs, _, entries = parse_specs(build_parser().parse_args(args))
    assert [spec.name for spec in specs] == ["ppo_seed0"] and list(entries) == ["ppo"]
    args = ["--env", "CartPole-v1", "--algos", "ppo", "--seeds", "1", "--config", f"a2c={tmp_path / 'none.yml'}"]
    assert list(parse_specs(build_parser().parse_args(args))[2]) == ["ppo"]


def test_config_gives_any_algorithm_its_defaults(tmp_path: Path) -> None:
    # Issue 62's study: a file with only a `default` entry trains PPO with SB3's defaults on an env rl_zoo3 has tuned
    defaults = tmp_path / "ppo_defaults.yml"
    defaults.write_text("default:\n  policy: 'MlpPolicy'\n  n_timesteps: !!float 1e6\n")
    args = ["--env", "CartPole-v1", "--algos", "ppo,a2c", "--seeds", "1", "--budget", "1000", "--config", f"ppo={defaults}"]
    specs, _, entries = parse_specs(build_parser().parse_args(args))
    assert entries["ppo"].fallback == "default" and entries["ppo"].source == defaults and entries["ppo"].n_envs == 1
    assert entries["ppo"].hyperparams == {"policy": "MlpPolicy", "n_timesteps": 1e6}
    assert entries["a2c"].fallback is None and entries["a2c"].n_envs == 8  # rl_zoo3's own CartPole-v1 entry
    assert [spec.config_path for spec in specs] == [str(defaults), None]


def test_code_version_without_git(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_git(*args: object, **kwargs: object) -> None:
        raise FileNotFoundError("git")

    monkeypatch.setattr(provenance.subprocess, "run", no_git)
    assert provenance.code_version() == {"sb3_reinforce": __version__, "git_commit": None, "git_dirty": None}


def test_seed_reproduction_tiny_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    seed_main(["--env", "CartPole-v1", "--episodes", "4", "--seeds", "1", "--workers", "1", "--out", str(tmp_path)])
    # Fewer episodes than the 100-episode window: no window mean, said so (not -inf)
    printed = capsys.readouterr().out
    assert "inf" not in printed and printed.count("n/a (fewer than 100 episodes)") == 2
    assert "| not reached | not reached |" in printed
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert summary[["best 100-episode mean", "final 100-episode mean"]].isna().all().all()
    episodes = pd.read_csv(tmp_path / "episodes.csv")
    assert list(episodes.columns) == EPISODE_COLUMNS
    assert list(episodes["episode"]) == [1, 2, 3, 4]
    assert (episodes["steps"].diff().dropna() == episodes["episode_length"].iloc[1:].to_numpy()).all()
    assert (tmp_path / "learning_curve.png").read_bytes()[:8] == PNG_MAGIC
    assert "| 0 | 4 |" in (tmp_path / "summary.md").read_text()


def test_seed_table_window_means() -> None:
    returns = np.arange(1.0, 151.0)  # episode i returns i
    episodes = pd.DataFrame(dict(seed=0, episode=np.arange(1, 151), steps=np.arange(1, 151) * 10, episode_return=returns))
    episodes["wall_time_s"] = 1.0
    row = seed_table(episodes, threshold=100.0).iloc[0]
    assert row["final 100-episode mean"] == np.mean(returns[50:]) == 100.5
    assert row["best 100-episode mean"] == 100.5
    # the first full window ending at or above 100: episodes 51..150
    assert row["episodes to a 100-episode mean of 100"] == 150 and row["steps to a 100-episode mean of 100"] == 1500
    shown = seed_table(episodes[episodes["episode"] <= 99], threshold=100.0)
    assert shown[["best 100-episode mean", "final 100-episode mean"]].isna().all().all()


def _legend_texts(fig: Figure) -> list[str]:
    legend = fig.axes[0].get_legend()
    assert legend is not None
    return [text.get_text() for text in legend.get_texts()]


def test_learning_curves_plot_the_points_every_seed_reached(tmp_path: Path) -> None:
    # seed 1's run ends past the budget and adds a 6th evaluation: one seed is no mean over seeds, so the curve stops
    # at the last point both seeds reached, the points the metric (best_mean) reads
    rows = [
        dict(algo="reinforce", seed=seed, eval_index=i, steps=10_000 * i, mean_return=float(i))
        for seed in (0, 1)
        for i in range(5)
    ]
    rows.append(dict(algo="reinforce", seed=1, eval_index=5, steps=50_100, mean_return=1000.0))
    fig = plot_learning_curves(pd.DataFrame(rows), None, tmp_path / "c.png", "t")
    line = fig.axes[0].lines[0]
    assert list(line.get_xdata()) == [0, 10_000, 20_000, 30_000, 40_000]
    assert max(line.get_ydata()) == 4.0
    assert best_mean(pd.DataFrame(rows), "mean_return") == (4.0, 0.0, 4)
    # One algorithm's rows without their algo column (benchmarks/mujoco_tuning.py's frames) read the same
    assert best_mean(pd.DataFrame(rows).drop(columns="algo"), "mean_return") == (4.0, 0.0, 4)
    # Each algorithm by its own seeds: PPO's single seed keeps all its points
    rows += [dict(algo="ppo", seed=0, eval_index=i, steps=10_000 * i, mean_return=0.0) for i in range(7)]
    kept = every_seed_reached(pd.DataFrame(rows)).groupby("algo")["eval_index"].max()
    assert kept.to_dict() == {"ppo": 6, "reinforce": 4}


def test_learning_curve_plots_name_their_band_and_separate_thousands(tmp_path: Path) -> None:
    rows = [
        dict(algo=algo, seed=seed, eval_index=i, steps=10_000 * i, mean_return=float(i + seed))
        for algo, seeds in (("reinforce", (0, 1)), ("ppo", (0,)))
        for seed in seeds
        for i in range(5)
    ]
    fig = plot_learning_curves(pd.DataFrame(rows), 475.0, tmp_path / "c.png", "CartPole-v1")
    assert (tmp_path / "c.png").read_bytes()[:8] == PNG_MAGIC
    assert _legend_texts(fig) == ["REINFORCE: mean over 2 seeds", "PPO: 1 seed (no band)", "solved (475)", BAND_LABEL]
    assert BAND_LABEL == "band: 95% bootstrap CI of the mean over seeds"
    ax = fig.axes[0]
    assert ax.xaxis.get_major_formatter()(20_000, 0) == "20,000"
    assert "20,000" in [label.get_text() for label in ax.get_xticklabels()]  # as drawn in the PNG
    assert ax.xaxis.get_offset_text().get_text() == ""  # no "1e4" beside the axis

    episodes = pd.DataFrame(dict(seed=np.repeat([0, 1, 2], 3000), episode=np.tile(np.arange(1, 3001), 3), episode_return=1.0))
    fig = plot_seed_curves(episodes, 200.0, tmp_path / "s.png", "LunarLander-v3")
    assert _legend_texts(fig) == ["seed's agent: mean over 3 seeds", "solved (200)", BAND_LABEL]
    assert "2,000" in [label.get_text() for label in fig.axes[0].get_xticklabels()]
    assert fig.axes[0].xaxis.get_offset_text().get_text() == ""


@pytest.mark.parametrize(
    "command, parser",
    [("compare", build_parser), ("seed", build_seed_parser), ("report", build_report_parser)],
)
def test_help_names_the_command_and_every_default(
    command: str, parser: Callable[[], argparse.ArgumentParser], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        cli_main([command, "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith(f"usage: sb3-reinforce {command} ")
    assert "``" not in text and ":mod:" not in text  # plain text, not the docstrings' reST
    options = text[text.index("options:") :]
    # One block per option: its line and the wrapped lines of its help
    blocks = {}
    for block in re.split(r"\n(?=  -)", options)[1:]:
        blocks[block.split()[0].rstrip(",")] = " ".join(block.split())
    for action in parser()._actions:
        if not action.option_strings or action.nargs == 0:  # positional, --help, flags
            continue
        help_text = blocks[action.option_strings[0]]
        if action.required:
            assert "(required)" in help_text, help_text
        else:
            assert "(default: " in help_text, help_text
            if action.default is not None:
                assert f"{action.default})" in help_text or f"{action.default}," in help_text, help_text


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGTERM, again while stopping"])
def test_stopping_seed_stops_its_workers(tmp_path: Path, sig: str) -> None:
    # As compare: the workers do not outlive the command, which says so in one line and exits 130.
    import sys

    cmd = [sys.executable, "-m", "sb3_reinforce.lab.cli", "seed", "--env", "CartPole-v1", "--episodes", "1000000"]
    cmd += ["--seeds", "1", "--workers", "1", "--out", str(tmp_path / "out")]
    episodes = tmp_path / "out" / "episodes_seed0.csv"
    # Stopped once the seed is training: its file has a finished episode
    output = stop_and_check_workers(cmd, sig, lambda: episodes.exists() and len(episodes.read_text().splitlines()) > 1)
    assert output.startswith("Interrupted: ") and output.count("\n") == 1, output


def test_reward_floor_cuts_the_episode() -> None:
    env = RewardFloor(gym.make("CartPole-v1"), floor=0.5)  # CartPole gives +1 per step: never below 0.5
    env.reset(seed=0)
    assert not any(env.step(0)[3] for _ in range(3))
    env = RewardFloor(gym.make("CartPole-v1"), floor=2.5)  # sum 1 after one step, 2 after two: below 2.5
    env.reset(seed=0)
    assert env.step(0)[3] and env.step(0)[3]
    env.reset(seed=0)  # the sum starts over
    assert env.step(0)[3]


def test_update_readme_markers(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text("a\n<!-- results:x/y -->\nold\n<!-- /results:x/y -->\nb\n")
    assert update_readme(readme, {"x/y": "| new |\n", "z": "t"}) == ["x/y"]
    assert readme.read_text() == "a\n<!-- results:x/y -->\n| new |\n<!-- /results:x/y -->\nb\n"


@pytest.mark.parametrize(
    "second_page",
    ["no marker\n", "<!-- t -->\nan opening marker alone\n", "<!-- /t -->\n<!-- t -->\nclosed before opened\n"],
)
def test_require_markers_names_the_page_without_its_pair(tmp_path: Path, second_page: str) -> None:
    good, bad = tmp_path / "good.md", tmp_path / "bad.md"
    good.write_text("<!-- t -->\nold\n<!-- /t -->\n")
    bad.write_text(second_page)
    require_markers([good], "t")  # the pair: nothing to say
    with pytest.raises(SystemExit, match=re.escape(f"--into {bad}: no <!-- t -->")):
        require_markers([good, bad], "t")
    with pytest.raises(SystemExit, match=r"^--page "):
        require_markers([bad], "t", option="--page")


@pytest.mark.parametrize(
    "vec_env, sig",
    [
        *((vec_env, sig) for vec_env in ("dummy", "subproc") for sig in ("SIGINT", "SIGTERM", "SIGTERM to the group")),
        ("dummy", "SIGTERM, again while stopping"),
    ],
)
def test_stopping_compare_stops_its_workers(tmp_path: Path, sig: str, vec_env: str) -> None:
    # Ctrl-C (SIGINT to the process group), `kill PID` (SIGTERM to the main process only), SIGTERM to the whole
    # process group, or SIGTERM repeated while the command stops (GNU timeout signals the command, then its group):
    # the workers, and the environment processes of --vec-env subproc, must not outlive the command, and the command
    # exits as interrupted (130).
    import sys

    cmd = [sys.executable, "-m", "sb3_reinforce.lab.compare", "--env", "CartPole-v1", "--algos", "reinforce"]
    # 2 runs on 1 worker of the local Dask cluster: the second waits on the scheduler while the first trains
    cmd += ["--seeds", "2", "--budget", "10000000", "--workers", "1", "--no-progress", "--out", str(tmp_path / "out")]
    cmd += ["--vec-env", vec_env]
    # Stopped once a run is training: its per-run CSV exists (written at the first evaluation, step 0)
    stop_and_check_workers(cmd, sig, lambda: bool(list((tmp_path / "out").glob(f"{PER_RUN_DIR}/*.csv"))))


def stop_and_check_workers(cmd: list[str], sig: str, training: "Callable[[], bool]") -> str:
    """
    Start ``cmd``, wait until ``training()``, send ``sig`` (SIGINT to the process group as Ctrl-C does, SIGTERM to
    the main process as ``kill PID``, "SIGTERM to the group" as ``kill -- -PGID``, or "SIGTERM, again while
    stopping": every 0.1 s for 2 s), check it exits 130 and leaves no worker running; return its output.
    """
    import signal
    import subprocess
    import time

    import psutil

    # As a terminal's foreground job: SIGINT at its default, whatever this process inherited (a job started with `&`
    # by a non-interactive shell ignores SIGINT, and so would the command: Python leaves an ignored SIGINT ignored)
    proc = subprocess.Popen(
        cmd,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        parent = psutil.Process(proc.pid)
        deadline = time.monotonic() + 120
        while not training():
            if proc.poll() is not None:  # its output is complete only once it has exited
                raise AssertionError(proc.stdout.read() if proc.stdout else "")
            assert time.monotonic() < deadline, "not training after 120 s"
            time.sleep(0.5)
        children = parent.children(recursive=True)
        assert children
        assert_localhost_only([proc.pid])  # the local cluster opens no port to the network
        if sig == "SIGINT":
            os.killpg(proc.pid, signal.SIGINT)
        elif sig == "SIGTERM to the group":  # `kill -- -PGID`, or a container being stopped
            os.killpg(proc.pid, signal.SIGTERM)
        elif sig == "SIGTERM, again while stopping":
            for _ in range(20):  # whenever the repeats land in the stopping, they change nothing
                proc.send_signal(signal.SIGTERM)
                time.sleep(0.1)
        else:
            proc.send_signal(signal.SIGTERM)
        output, _ = proc.communicate(timeout=60)
        assert proc.returncode == 130, output
        _, alive = psutil.wait_procs(children, timeout=30)
        assert not alive, f"workers left running: {alive}"
    finally:  # a failed check leaves nothing running
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        if proc.stdout:
            proc.stdout.close()
    return output


def _fake_comparison(folder: Path, env_id: str, threshold: float, curves: dict[tuple[str, int], list[float]]) -> None:
    """A comparison folder as compare writes it: comparison.json, per_run/ CSVs and JSONs, then its outputs."""
    (folder / PER_RUN_DIR).mkdir(parents=True)
    (folder / "comparison.json").write_text(json.dumps(dict(env=env_id, threshold=threshold)))
    for (algo, seed), returns in curves.items():
        rows = [
            dict(env=env_id, algo=algo, seed=seed, eval_index=i, steps=1000 * i, episodes=i, wall_time_s=2.0 * i)
            | dict(mean_return=r, std_return=0.0, mean_return_stochastic=r - 1, std_return_stochastic=0.0, peak_rss_mb=1.0)
            for i, r in enumerate(returns)
        ]
        pd.DataFrame(rows, columns=RESULT_COLUMNS).to_csv(folder / PER_RUN_DIR / f"{algo}_seed{seed}.csv", index=False)
        spec = dict(algo=algo, seed=seed, env_id=env_id)
        (folder / PER_RUN_DIR / f"{algo}_seed{seed}.json").write_text(
            json.dumps(dict(spec=spec, steps_per_s=1.0, peak_rss_mb=1.0, cpu_time_s=1.0))
        )
    write_outputs(folder, env_id, threshold)


def test_report_into_a_page_leaves_out_the_seconds(tmp_path: Path) -> None:
    # A page's copy of a comparison's table (report --readme) has no seconds to the threshold: runs made apart compare
    # no time. The folder's summary.md keeps them, and every other cell is its own, as written.
    from sb3_reinforce.lab.report import main as report

    folder = tmp_path / "cmp"
    _fake_comparison(folder, "CartPole-v1", 5.0, {("reinforce", 10): [0, 5, 6, 7], ("ppo", 0): [0, 1, 5, 5]})
    name = folder.as_posix()
    page = tmp_path / "page.md"
    page.write_text(f"a\n<!-- results:{name} -->\nold\n<!-- /results:{name} -->\nb\n")
    report([name, "--readme", str(page)])
    written = [[cell.strip() for cell in line.split("|")[1:-1]] for line in page.read_text().splitlines()[2:-2]]
    summary = [[cell.strip() for cell in line.split("|")[1:-1]] for line in (folder / "summary.md").read_text().splitlines()]
    dropped = summary[0].index("seconds to 5, median [IQR]")
    assert summary[2][dropped] == "2.0 [2.0, 2.0] (1/1 reached)"  # REINFORCE reaches 5 at its first trained evaluation
    assert not any(cell.startswith("seconds") for cell in written[0])
    assert written == [row[:dropped] + row[dropped + 1 :] for row in summary]


def test_overview_table_hand_computed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # REINFORCE on seeds 10-12 (reaching 5 at 2,000 and 3,000 steps, one never), PPO on seed 0 in the first
    # folder; the second folder's PPO row is shadowed by the first's, its A2C row is new.
    first, second = tmp_path / "first", tmp_path / "second"
    _fake_comparison(
        first,
        "CartPole-v1",
        5.0,
        {
            ("reinforce", 10): [9, 1, 5, 6],
            ("reinforce", 11): [0, 1, 2, 7],
            ("reinforce", 12): [0, 1, 1, 1],
            ("ppo", 0): [0, 5, 5, 5],
        },
    )
    _fake_comparison(second, "CartPole-v1", 5.0, {("ppo", 0): [0, 0, 0, 0], ("a2c", 0): [0, 0, 0, 3]})
    table = overview_table([first, second])
    assert list(table["algorithm"]) == ["REINFORCE", "PPO", "A2C"]
    reinforce, ppo, a2c = (table.iloc[i] for i in range(3))
    # seed 10 scores 9 before training (eval_index 0): not counted; it reaches 5 at 2,000 steps, seed 11 at 3,000
    assert reinforce["seeds reaching"] == "2/3 (seeds 10-12)"
    assert reinforce["median steps to reach"] == "3,000"  # median of 2,000, 3,000 and never
    assert "median seconds to reach" not in table  # seconds of runs made apart compare nothing
    # IQM of 3 values (trim_mean 0.25 drops none): mean(6, 7, 1), and of the sampled-action finals mean(5, 6, 0)
    assert reinforce["final IQM"] == "4.7" and reinforce["final IQM, sampled actions"] == "3.7"
    assert reinforce["budget"] == "3k" and reinforce["env (threshold)"] == "CartPole-v1 (5)"
    assert ppo["seeds reaching"] == "1/1 (seeds 0)" and ppo["folder"] == f"`{first.as_posix()}`"
    assert a2c["seeds reaching"] == "0/1 (seeds 0)" and a2c["median steps to reach"] == "not reached"
    # the report command writes it between the summary markers
    page = tmp_path / "page.md"
    page.write_text("a\n<!-- summary -->\nold\n<!-- /summary -->\nb\n")
    render_main([str(first), str(second), "--summary", str(page)])
    assert page.read_text() == "a\n<!-- summary -->\n" + to_markdown(table) + "<!-- /summary -->\nb\n"
    assert "summary updated" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        render_main([str(first), "--summary", str(tmp_path / "first" / "summary.md")])  # no markers there


def test_published_table_hand_computed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # REINFORCE on seeds 0-1 over 2,000 steps (evaluations at 0, 1,000 and 2,000): mean curve 1.5, 3.5, 2.5 (best
    # 3.5, std 0.5 at the second point); its sampled-action curve is one lower everywhere (best 2.5)
    folder = tmp_path / "run"
    _fake_comparison(folder, "Hopper-v4", 3.0, {("reinforce", 0): [1, 3, 4], ("reinforce", 1): [2, 4, 1]})
    published = pd.DataFrame(
        [
            dict(env_id="Hopper-v4", source="A", budget=2000, mean=2.0, std=0.5, approximate=False),
            dict(env_id="Hopper-v4", source="B", budget=2000, mean=3.0, std=np.nan, approximate=True),
            # C evaluates deterministic actions: held against the deterministic figure (3.5) only
            dict(env_id="Hopper-v4", source="C", budget=2000, mean=3.0, std=np.nan, deterministic=True),
            dict(env_id="Hopper-v4", source="A", budget=10000, mean=9.0, std=np.nan, approximate=False),
            dict(env_id="Ant-v4", source="A", budget=2000, mean=1.0, std=0.1, approximate=False),
        ]
    )
    table = published_table([folder], published)
    hopper, ant = table.iloc[0], table.iloc[1]
    assert (hopper["A, 2k"], hopper["B, 2k"], hopper["A, 10k"]) == ("2 ± 0.5", "~3", "9")
    assert hopper["REINFORCE here"] == "3.5 ± 0.5 (2k)" and hopper["REINFORCE here, sampled actions"] == "2.5 ± 0.5"
    # Judged by the lower figure (2.5): above A's 2, below B's 3; C by the deterministic one (3.5 >= 3); the 10k
    # number is another budget
    assert hopper["at or above the published"] == "below B (3)"
    published.loc[published["source"] == "C", "mean"] = 3.6
    assert published_table([folder], published).iloc[0]["at or above the published"] == "below B (3), C (3.6)"
    published.loc[published["source"] == "C", "mean"] = 3.0
    assert hopper["final IQM [95% CI]"].startswith("2.5 [") and hopper["seeds"] == "0, 1"
    assert ant["REINFORCE here"] == "not measured yet" and ant["A, 2k"] == "1 ± 0.1"
    # A seed still running counts only at the points both have reached: seed 2 stops after the first point
    _fake_comparison(tmp_path / "partial", "Hopper-v4", 3.0, {("reinforce", 0): [1, 3, 4], ("reinforce", 2): [5]})
    assert published_table([tmp_path / "partial"], published).iloc[0]["REINFORCE here"].startswith("3.0 ± 2.0")
    # The report command prints it and writes it between the published markers
    csv_path, page = tmp_path / "published.csv", tmp_path / "page.md"
    published.to_csv(csv_path, index=False)
    page.write_text("a\n<!-- published -->\nold\n<!-- /published -->\nb\n")
    render_main([str(folder), "--published", str(csv_path), "--published-into", str(page)])
    assert page.read_text() == "a\n<!-- published -->\n" + to_markdown(table) + "<!-- /published -->\nb\n"
    assert "published table updated" in capsys.readouterr().out
    # Another algorithm of the folders against its own published numbers, between its own markers
    _fake_comparison(tmp_path / "ppo", "Hopper-v4", 3.0, {("ppo", 0): [0, 4, 2], ("reinforce", 0): [1, 1, 1]})
    page.write_text("<!-- published:ppo -->\nold\n<!-- /published:ppo -->\n")
    render_main(
        [str(tmp_path / "ppo"), "--published", str(csv_path), "--published-algo", "ppo", "--published-into", str(page)]
    )
    ppo_table = published_table([tmp_path / "ppo"], published, "ppo")
    assert ppo_table.iloc[0]["PPO here"].startswith("4.0 ± 0.0") and "REINFORCE here" not in ppo_table
    assert page.read_text() == "<!-- published:ppo -->\n" + to_markdown(ppo_table) + "<!-- /published:ppo -->\n"
    for bad in (
        ["--published-into", str(page)],
        ["--published", str(tmp_path / "none.csv")],
        ["--published-algo", "ppo"],
        ["--published", str(csv_path), "--published-algo", "nosuchalgo"],
        ["--published", str(csv_path), "--published-into", str(page)],  # the page has PPO's markers only
    ):
        with pytest.raises(SystemExit):
            render_main([str(folder), *bad])


def test_seed_curves_of_seeds_stopped_early_are_drawn_one_per_seed(tmp_path: Path) -> None:
    # seed 1 stopped after 30 episodes: a mean over seeds would end there, so each seed has its own line, no band
    rows = [dict(seed=0, episode=i, episode_return=-1000.0 * i) for i in range(1, 51)]
    rows += [dict(seed=1, episode=i, episode_return=-5.0) for i in range(1, 31)]
    fig = plot_seed_curves(pd.DataFrame(rows), -110.0, tmp_path / "curve.png", "t", window=10)
    texts = _legend_texts(fig)
    assert "seed 0 (50 episodes)" in texts and "seed 1 (30 episodes)" in texts and BAND_LABEL not in texts
    assert fig.axes[0].get_yscale() == "symlog"  # returns down to -50,000 against a threshold of -110
    assert [len(line.get_xdata()) for line in fig.axes[0].get_lines()[:2]] == [50, 30]


def test_evaluation_batch_plays_evaluate_policys_episodes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A run's deterministic episodes stepped side by side give evaluate_policy's returns to the bit, and leave the
    # evaluation env as evaluate_policy would: the sampled-action evaluation after it is unchanged too
    from sb3_reinforce.lab.compare import evaluation

    def one_run(folder: Path) -> pd.DataFrame:
        runner.run(RunSpec("CartPole-v1", "reinforce", 3, 6000, 1000, 5), folder)
        return pd.read_csv(folder / PER_RUN_DIR / "reinforce_seed3.csv")

    batched = one_run(tmp_path / "batched")
    monkeypatch.setattr(experiment, "episode_batch", lambda *args: None)  # evaluate_policy, one episode after another
    sequential = one_run(tmp_path / "sequential")
    columns = ["steps", "episodes", "mean_return", "std_return", "mean_return_stochastic", "std_return_stochastic"]
    assert batched[columns].equals(sequential[columns]), pd.concat([batched[columns], sequential[columns]], axis=1)
    assert batched["mean_return"].nunique() > 2  # the policy changes, and with it the returns: not a trivial match
    # Used where the env draws only on reset (CartPole), not where it draws while it steps (LunarLander's particles)
    assert evaluation.draws_only_on_reset(gym.make("CartPole-v1"))
    assert not evaluation.draws_only_on_reset(gym.make("LunarLander-v3"))
