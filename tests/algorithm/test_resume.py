"""Interrupt and resume: stops from callbacks, KeyboardInterrupt from a callback or the env, save/load/continue."""

import pathlib
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards import load_with_random_state, save_with_random_state

LENGTH = 5  # every episode of ChainEnv lasts 5 steps: updates (n_envs=1, n_episodes=1) happen every 5 steps


class ChainEnv(gym.Env):
    """Deterministic: reset always gives the same observation, the next state depends only on (t, action)."""

    def __init__(self, interrupt_at: int | None = None):
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)
        self.interrupt_at = interrupt_at  # raise KeyboardInterrupt at this step call (counted over the env's life)
        self.calls = 0
        self.t = 0
        self.last = 0

    def _obs(self) -> np.ndarray:
        return np.array([self.t / LENGTH, self.last], dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.t, self.last = 0, 0
        return self._obs(), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.calls += 1
        if self.calls == self.interrupt_at:
            raise KeyboardInterrupt  # before any state change, like Ctrl-C while waiting for the env
        reward = float(action == self.t % 2)
        self.t += 1
        self.last = int(action)
        return self._obs(), reward, self.t >= LENGTH, False, {}


def make_env(n_envs: int = 1, interrupt_at: int | None = None) -> DummyVecEnv:
    return DummyVecEnv([lambda: Monitor(ChainEnv(interrupt_at))] + [lambda: Monitor(ChainEnv())] * (n_envs - 1))


def make_model(env: DummyVecEnv, baseline: str | None = None, learning_rate: Any = 3e-3) -> REINFORCE:
    kwargs = dict(baseline=baseline, learning_rate=learning_rate, policy_kwargs=dict(net_arch=[16]), seed=0)
    return REINFORCE("MlpPolicy", env, **kwargs)


def state(model: REINFORCE) -> dict[str, Any]:
    optimizer = model.policy.optimizer.state_dict()
    return {
        "params": [p.detach().clone() for p in model.policy.parameters()],
        "adam": [(s["exp_avg"].clone(), s["exp_avg_sq"].clone(), float(s["step"])) for s in optimizer["state"].values()],
        "lr": optimizer["param_groups"][0]["lr"],
        "num_timesteps": model.num_timesteps,
        "n_updates": model._n_updates,
        "episodes": [(e["r"], e["l"]) for e in model.ep_info_buffer],
    }


def assert_same(a: dict[str, Any], b: dict[str, Any]) -> None:
    for x, y in zip(a["params"], b["params"], strict=True):
        th.testing.assert_close(x, y, rtol=0, atol=1e-6)
    for (m1, v1, s1), (m2, v2, s2) in zip(a["adam"], b["adam"], strict=True):
        th.testing.assert_close(m1, m2, rtol=0, atol=1e-6)
        th.testing.assert_close(v1, v2, rtol=0, atol=1e-9)
        assert s1 == s2
    assert len(a["adam"]) == len(b["adam"]) > 0
    for key in ("lr", "num_timesteps", "n_updates", "episodes"):
        assert a[key] == b[key], key


class StopAt(BaseCallback):
    def __init__(self, at: int, interrupt: bool = False):
        super().__init__()
        self.at, self.interrupt = at, interrupt

    def _on_step(self) -> bool:
        if self.num_timesteps == self.at:
            if self.interrupt:
                raise KeyboardInterrupt
            return False
        return True


TOTAL = 30 * LENGTH


@pytest.mark.parametrize("n_envs", [1, 2])
@pytest.mark.parametrize("how", ["callback", "keyboard_interrupt_in_callback", "keyboard_interrupt_in_env"])
def test_interrupted_run_resumes_in_process_exactly(how: str, n_envs: int) -> None:
    """Stopped mid-episode (mid-batch), then continued: identical to the uninterrupted run, nothing lost."""
    schedule = LinearSchedule(3e-3, 1e-4, 1.0)
    reference = make_model(make_env(n_envs), learning_rate=schedule).learn(TOTAL)

    stop_at = 12 * n_envs + n_envs  # in the middle of an episode and of a batch
    env = make_env(n_envs, interrupt_at=13 if how == "keyboard_interrupt_in_env" else None)
    model = make_model(env, learning_rate=schedule)
    if how == "callback":
        model.learn(TOTAL, callback=StopAt(stop_at))
    else:
        with pytest.raises(KeyboardInterrupt):
            model.learn(TOTAL, callback=StopAt(stop_at, interrupt=how == "keyboard_interrupt_in_callback"))
    # A consistent model: counters, buffer and last observation agree
    expected_steps = stop_at if how != "keyboard_interrupt_in_env" else 12 * n_envs
    assert model.num_timesteps == expected_steps
    assert model.rollout_buffer.size() == expected_steps - LENGTH * n_envs * model._n_updates
    model.learn(TOTAL - model.num_timesteps, reset_num_timesteps=False)
    assert model._total_timesteps == TOTAL, "the learning-rate schedule's progress is measured on the whole run"
    if how != "keyboard_interrupt_in_env":
        assert_same(state(model), state(reference))
    else:
        # The action drawn for the interrupted step was never played: from there the random stream is shifted by
        # one draw, so the weights differ, but no step was lost or counted twice.
        resumed, expected = state(model), state(reference)
        for key in ("num_timesteps", "n_updates"):
            assert resumed[key] == expected[key], key
        assert [length for _, length in resumed["episodes"]] == [length for _, length in expected["episodes"]]


@pytest.mark.parametrize("baseline", [None, "value"])
def test_save_load_resume_equals_uninterrupted_run(tmp_path: pathlib.Path, baseline: str | None) -> None:
    """
    N steps, save, load, M more steps == N + M steps in one go (deterministic env, same seed), when the save
    happens between updates: the random-generator states saved with it (sb3_reinforce.safeguards) make the
    resumed run draw the same actions.
    """
    n, m = 12 * LENGTH, 10 * LENGTH
    reference = make_model(make_env(), baseline).learn(n + m)

    save_with_random_state(make_model(make_env(), baseline).learn(n), tmp_path / "model.zip")
    model = load_with_random_state(REINFORCE, tmp_path / "model.zip", env=make_env())
    assert model.num_timesteps == n and model._n_updates == n // LENGTH
    model.learn(m, reset_num_timesteps=False)
    assert_same(state(model), state(reference))

    # SB3's own load reseeds the generators from `seed`: the resumed run then draws other actions.
    plain = REINFORCE.load(tmp_path / "model.zip", env=make_env())
    plain.learn(m, reset_num_timesteps=False)
    assert not all(th.equal(a, b) for a, b in zip(state(plain)["params"], state(reference)["params"], strict=True))


@pytest.mark.parametrize("how", ["callback", "keyboard_interrupt_in_callback", "keyboard_interrupt_in_env"])
def test_interrupted_run_saves_and_resumes(tmp_path: pathlib.Path, how: str) -> None:
    """
    Interrupted mid-episode, saved, loaded: counters, episode statistics, optimizer state and the schedule's
    progress are those of the interrupted run, and training continues the same schedule.
    """
    schedule = LinearSchedule(3e-3, 1e-4, 1.0)
    env = make_env(interrupt_at=13 if how == "keyboard_interrupt_in_env" else None)
    model = make_model(env, learning_rate=schedule)
    if how == "callback":
        model.learn(TOTAL, callback=StopAt(13))
    else:
        with pytest.raises(KeyboardInterrupt):
            model.learn(TOTAL, callback=StopAt(13, interrupt=how == "keyboard_interrupt_in_callback"))
    before = state(model)
    progress = model._current_progress_remaining
    model.save(tmp_path / "interrupted")

    loaded = REINFORCE.load(tmp_path / "interrupted", env=make_env())
    assert_same(state(loaded), before)
    assert loaded._current_progress_remaining == progress and loaded._total_timesteps == TOTAL
    loaded.learn(TOTAL - loaded.num_timesteps, reset_num_timesteps=False)
    assert loaded._total_timesteps == TOTAL
    assert loaded.num_timesteps >= TOTAL
    # The last update used the schedule at the whole run's progress, not a restarted one
    assert loaded.policy.optimizer.param_groups[0]["lr"] == pytest.approx(schedule(1 - loaded.num_timesteps / TOTAL))
    assert loaded._n_updates > before["n_updates"]
    # The steps taken since the last update before the save were not trained on: the env restarts an episode.
    assert len(loaded.ep_info_buffer) == len(before["episodes"]) + loaded._n_updates - before["n_updates"]
