"""A comparison run interrupted after an evaluation resumes from its checkpoint instead of starting over."""

import json
import multiprocessing as mp
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from sb3_reinforce.lab.compare import runner
from sb3_reinforce.lab.compare.command import write_outputs
from sb3_reinforce.lab.compare.experiment import build_run
from sb3_reinforce.lab.compare.folder import PER_RUN_DIR, RESULT_COLUMNS, ComparisonFolder, RunSpec
from sb3_reinforce.lab.compare.runner import exploration_noise_to_policy_device
from sb3_reinforce.lab.resource_use import process_tree_cpu_s


class _Stop(Exception):
    pass


def _stop_after(n_evaluations: int) -> Callable[[int], None]:
    calls = []

    def progress(steps: int) -> None:
        calls.append(steps)
        if len(calls) == n_evaluations:
            raise _Stop(steps)

    return progress


def _training_log(runs_dir: Path, spec: RunSpec) -> list[dict[str, float]]:
    return [json.loads(line) for line in (runs_dir / f"{spec.name}.train.jsonl").read_text().splitlines()]


def _checkpoint_files(runs_dir: Path, spec: RunSpec) -> list[Path]:
    return sorted(runs_dir.glob(f"{spec.name}.checkpoint*"))


@pytest.mark.parametrize("algo", ["reinforce", "ppo"])
def test_interrupted_run_resumes_from_its_last_evaluation(tmp_path: Path, algo: str) -> None:
    spec = RunSpec("CartPole-v1", algo, 3, budget=4000, eval_freq=1000, n_eval_episodes=2)
    runs_dir = tmp_path / PER_RUN_DIR
    with pytest.raises(_Stop):
        runner.run(spec, tmp_path, progress=_stop_after(3))  # stopped right after evaluations 0, 1 and 2
    state = json.loads((runs_dir / f"{spec.name}.checkpoint.json").read_text())
    assert state["spec"] == spec.identity() and state["counters"]["eval_index"] == 3
    assert ComparisonFolder(tmp_path).load_summaries() == {}  # a checkpoint is not a finished run: the report skips it
    assert write_outputs(tmp_path, "CartPole-v1", 475.0) is None
    stopped_at = int(state["counters"]["steps"])
    assert 2000 <= stopped_at < 3000 and state["cpu_time_s"] > 0
    before = pd.read_csv(runs_dir / f"{spec.name}.csv")
    assert list(before["eval_index"]) == [0, 1, 2]
    log_before = _training_log(runs_dir, spec)
    assert [record["eval_index"] for record in log_before] == [0, 1, 2]
    # A row written after the checkpoint (a crash between the two) is dropped on resume, in both files
    with (runs_dir / f"{spec.name}.csv").open("a") as f:
        f.write(",".join(["CartPole-v1", algo, "3", "3", "9999", "1", "1", "1", "0", "1", "0", "1"]) + "\n")
    with (runs_dir / f"{spec.name}.train.jsonl").open("a") as f:
        f.write(json.dumps({"eval_index": 3, "steps": 9999}) + "\n")

    summary = runner.run(spec, tmp_path)
    assert summary["resumed_at_steps"] == [stopped_at]
    assert summary["steps"] >= 4000
    after = pd.read_csv(runs_dir / f"{spec.name}.csv")
    assert list(after.columns) == RESULT_COLUMNS
    # 0, 1k, 2k, 3k, 4k, and one at the end where whole episodes ran past the budget
    assert list(after["eval_index"]) == list(range(len(after))) and len(after) in (5, 6)
    pd.testing.assert_frame_equal(after.iloc[:3], before)  # the rows before the stop are kept as they were
    assert list(after["steps"]) == sorted(after["steps"]) and 9999 not in set(after["steps"])
    assert list(after["wall_time_s"]) == sorted(after["wall_time_s"])  # training time goes on counting
    assert after["episodes"].iloc[3] > after["episodes"].iloc[2]
    assert _checkpoint_files(runs_dir, spec) == []  # finished: no checkpoint left
    # The training log: a line per evaluation, at its steps; the last update's losses and the training episodes' mean
    # return from the first evaluation after an update on (the untrained one has none)
    log = _training_log(runs_dir, spec)
    assert log[:3] == log_before
    assert [(r["eval_index"], r["steps"]) for r in log] == list(zip(after["eval_index"], after["steps"], strict=True))
    assert set(log[0]) == {"eval_index", "steps"}
    loss = "train/policy_loss" if algo == "reinforce" else "train/policy_gradient_loss"
    assert all(loss in record and record["rollout/ep_rew_mean"] > 0 for record in log[1:]), log
    assert "train/std" not in log[1]  # CartPole's actions are discrete: no Gaussian


def test_a_run_may_resume_with_the_other_vec_env(tmp_path: Path) -> None:
    # --vec-env is how the environments are stepped, not what the run is: a run started in one process goes on with
    # one process per environment (SubprocVecEnv), and its summary says which part ran how
    spec = RunSpec("CartPole-v1", "reinforce", 5, budget=4000, eval_freq=1000, n_eval_episodes=2)
    state_path = tmp_path / PER_RUN_DIR / f"{spec.name}.checkpoint.json"
    with pytest.raises(_Stop):
        runner.run(spec, tmp_path, progress=_stop_after(2))
    state = json.loads(state_path.read_text())
    assert state.pop("vec_envs") == ["dummy"] and state.pop("devices") == ["cpu"]
    state_path.write_text(json.dumps(state))  # as a checkpoint written before the kind and device were recorded
    built: list[Any] = []
    original_build_run = runner.build_run

    def spy(*args: Any, **kwargs: Any) -> Any:
        built.append(original_build_run(*args, **kwargs))
        return built[-1]

    with pytest.MonkeyPatch.context() as patch, pytest.raises(_Stop):
        patch.setattr(runner, "build_run", spy)
        runner.run(spec, tmp_path, progress=_stop_after(2), vec_env="subproc")  # training start, one evaluation
    assert isinstance(built[0].train_env.unwrapped, SubprocVecEnv)
    assert isinstance(built[0].eval_env.unwrapped, DummyVecEnv)  # one evaluation env: no process of its own
    built[0].train_env.close()
    assert json.loads(state_path.read_text())["vec_envs"] == ["dummy", "subproc"]
    summary = runner.run(spec, tmp_path)
    assert summary["vec_envs"] == ["dummy", "subproc", "dummy"] and len(summary["resumed_at_steps"]) == 2
    assert summary["steps"] >= 4000
    assert summary["devices"] == ["cpu", "cpu", "cpu"]


@pytest.mark.skipif(not th.cuda.is_available(), reason="needs a CUDA device")
@pytest.mark.parametrize("env_id, algo", [("CartPole-v1", "reinforce"), ("CartPole-v1", "ppo"), ("Pendulum-v1", "ppo")])
def test_a_run_may_resume_on_another_device(tmp_path: Path, env_id: str, algo: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # --device is where the networks compute, not what the run is: a run started on the GPU goes on on the CPU from
    # its checkpoint (and back), and its summary says which part ran where. PPO's Pendulum-v1 entry uses gSDE, whose
    # exploration matrix SB3 leaves on the CPU until the first rollout: the evaluation before it must still run.
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)  # conftest hides the GPU from every other test
    spec = RunSpec(env_id, algo, 6, budget=3000, eval_freq=1000, n_eval_episodes=2)
    state_path = tmp_path / PER_RUN_DIR / f"{spec.name}.checkpoint.json"
    devices: list[th.device] = []
    original_build_run = runner.build_run

    def spy(*args: Any, **kwargs: Any) -> Any:
        built = original_build_run(*args, **kwargs)
        devices.append(built.model.device)
        return built

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(runner, "build_run", spy)
        with pytest.raises(_Stop):
            runner.run(spec, tmp_path, progress=_stop_after(2), device="cuda")
        assert json.loads(state_path.read_text())["devices"] == ["cuda"]
        with pytest.raises(_Stop):
            runner.run(spec, tmp_path, progress=_stop_after(2), device="cpu")
        summary = runner.run(spec, tmp_path, device="cuda")
    assert [device.type for device in devices] == ["cuda", "cpu", "cuda"]
    assert summary["devices"] == ["cuda", "cpu", "cuda"] and len(summary["resumed_at_steps"]) == 2
    assert summary["steps"] >= 3000


BUSY_FOR_ONE_CPU_SECOND = "import time\nend = time.process_time() + 1.0\nwhile time.process_time() < end: pass\n"


def test_cpu_time_counts_the_processes_below() -> None:
    # A SubprocVecEnv's environments run in processes of their own: a run's CPU seconds count them, while they run
    # and once they have ended and been waited for
    before = process_tree_cpu_s()
    child = subprocess.Popen([sys.executable, "-c", BUSY_FOR_ONE_CPU_SECOND + "time.sleep(60)"])
    try:
        deadline = time.monotonic() + 60
        while process_tree_cpu_s() - before < 0.9:
            assert time.monotonic() < deadline, "the child's CPU seconds were not counted"
            time.sleep(0.1)
    finally:
        child.kill()
        child.wait()
    assert process_tree_cpu_s() - before >= 0.9  # waited for: in this process's children_user/system


def test_cpu_time_counts_processes_a_forkserver_waited_for() -> None:
    # SubprocVecEnv's default start method: the environment processes are children of a forkserver (a child of this
    # process that outlives them), which waits for them when they end
    context = mp.get_context("forkserver")
    warm_up = context.Process(target=exec, args=("pass",))  # starts the forkserver, if this process has none yet
    warm_up.start()
    warm_up.join()
    before = process_tree_cpu_s()
    busy = context.Process(target=exec, args=(BUSY_FOR_ONE_CPU_SECOND,))
    busy.start()
    busy.join()
    assert busy.exitcode == 0
    assert process_tree_cpu_s() - before >= 0.9


def test_checkpoint_restores_weights_optimizers_steps_schedule_and_normalization(tmp_path: Path) -> None:
    # Normalized observations and rewards (VecNormalize), a value baseline fitted by an optimizer of its own, a
    # decaying learning rate: all of it must come back.
    config = tmp_path / "reinforce.yml"
    config.write_text(
        "Pendulum-v1:\n  normalize: true\n  n_envs: 2\n  n_timesteps: 10000\n  policy: MlpPolicy\n  baseline: value\n"
        "  n_value_steps: 3\n  learning_rate: lin_1e-3\n"
    )
    spec = RunSpec("Pendulum-v1", "reinforce", 0, budget=10_000, eval_freq=500, n_eval_episodes=1, config_path=str(config))
    built = build_run("reinforce", "Pendulum-v1", 0, 10_000, tmp_path / "zoo", config)
    built.model.learn(1200)
    original = built.model
    assert original.value_optimizer is not None and original._current_progress_remaining < 1
    checkpoint = ComparisonFolder(tmp_path).checkpoint(spec, {"learning_rate": "lin_1e-3"})
    checkpoint.save(original, dict(eval_index=2, steps=original.num_timesteps, episodes=6, train_time_s=1.0, peak_rss_mb=1.0))

    fresh = build_run("reinforce", "Pendulum-v1", 0, 10_000, tmp_path / "zoo2", config)
    state = checkpoint.load_state()
    assert state is not None
    restored = checkpoint.restore(fresh.model, state)
    assert restored.num_timesteps == original.num_timesteps and restored._n_updates == original._n_updates
    assert restored._current_progress_remaining == original._current_progress_remaining
    assert restored.lr_schedule(0.5) == pytest.approx(0.5e-3)
    for a, b in zip(original.policy.state_dict().values(), restored.policy.state_dict().values(), strict=True):
        assert th.equal(a, b)
    for saved_optimizer, restored_optimizer in (
        (original.policy.optimizer, restored.policy.optimizer),
        (original.value_optimizer, restored.value_optimizer),
    ):
        saved, loaded = saved_optimizer.state_dict(), restored_optimizer.state_dict()
        assert saved["state"].keys() == loaded["state"].keys() and saved["state"]
        for key in saved["state"]:
            assert th.equal(saved["state"][key]["exp_avg"], loaded["state"][key]["exp_avg"])
    saved_norm, loaded_norm = original.get_vec_normalize_env(), restored.get_vec_normalize_env()
    assert saved_norm is not None and loaded_norm is not None and loaded_norm is fresh.model.get_vec_normalize_env()
    np.testing.assert_array_equal(saved_norm.obs_rms.mean, loaded_norm.obs_rms.mean)
    np.testing.assert_array_equal(saved_norm.ret_rms.var, loaded_norm.ret_rms.var)
    assert checkpoint.resumed_at_steps == [original.num_timesteps]
    # the same run with other hyperparameters in its file is not resumed from this checkpoint
    assert ComparisonFolder(tmp_path).checkpoint(spec, {"learning_rate": "lin_3e-3"}).load_state() is None


def test_checkpoint_of_other_settings_or_incomplete_is_ignored(tmp_path: Path) -> None:
    spec = RunSpec("CartPole-v1", "reinforce", 0, budget=2000, eval_freq=1000, n_eval_episodes=1)
    with pytest.raises(_Stop):
        runner.run(spec, tmp_path, progress=_stop_after(2))
    other = RunSpec("CartPole-v1", "reinforce", 0, budget=3000, eval_freq=1000, n_eval_episodes=1)
    state_path = tmp_path / PER_RUN_DIR / f"{spec.name}.checkpoint.json"
    hyperparams = json.loads(state_path.read_text())["hyperparams"]
    assert hyperparams["n_timesteps"] and "policy" in hyperparams  # the zoo entry, as the summary records it
    assert ComparisonFolder(tmp_path).checkpoint(other, hyperparams).load_state() is None  # same files, other settings
    assert ComparisonFolder(tmp_path).checkpoint(spec, hyperparams).load_state() is not None
    state_path.write_text("{")  # damaged
    assert ComparisonFolder(tmp_path).checkpoint(spec, hyperparams).load_state() is None
    state_path.unlink()  # a save that did not finish
    assert ComparisonFolder(tmp_path).checkpoint(spec, hyperparams).load_state() is None
    summary = runner.run(spec, tmp_path)  # started over
    assert "resumed_at_steps" not in summary
    rows = pd.read_csv(tmp_path / PER_RUN_DIR / f"{spec.name}.csv")  # one run's rows, from step 0
    assert list(rows["eval_index"]) == list(range(len(rows))) and len(rows) >= 3 and rows["steps"].iloc[0] == 0
    assert _checkpoint_files(tmp_path / PER_RUN_DIR, spec) == []


def test_off_policy_runs_are_not_checkpointed(tmp_path: Path) -> None:
    # model.save leaves the replay buffer out: a resumed DQN would restart on an empty buffer, so it starts over
    spec = RunSpec("CartPole-v1", "dqn", 0, budget=2000, eval_freq=500, n_eval_episodes=1)
    with pytest.raises(_Stop):
        runner.run(spec, tmp_path, progress=_stop_after(3))
    assert _checkpoint_files(tmp_path / PER_RUN_DIR, spec) == []
    summary = runner.run(spec, tmp_path)
    assert "resumed_at_steps" not in summary and summary["steps"] >= 2000


def test_exploration_noise_is_moved_not_drawn_again(tmp_path: Path) -> None:
    # The gSDE matrices a run starts with are the ones drawn when its policy was built: putting them on the policy's
    # device draws nothing (the same values, the random generators where they were)
    built = build_run("ppo", "Pendulum-v1", 3, 2048, tmp_path)  # rl_zoo3's PPO entry for Pendulum-v1 uses gSDE
    distribution = built.model.policy.action_dist
    before = distribution.exploration_mat.clone(), distribution.exploration_matrices.clone()
    rng = th.get_rng_state()
    exploration_noise_to_policy_device(built.model)
    assert th.equal(distribution.exploration_mat, before[0]) and th.equal(distribution.exploration_matrices, before[1])
    assert distribution.exploration_mat.device == built.model.policy.device
    assert th.equal(th.get_rng_state(), rng)
    built.train_env.close()
    built.eval_env.close()
