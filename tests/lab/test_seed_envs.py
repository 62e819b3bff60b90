"""The seed's environments (time limits, CarRacing's pixels and actions) and the seed re-run's early stops."""

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest
import torch as th
from gymnasium import spaces

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.seed.envs import OneHotActions, SeedPixels, make_seed_env
from sb3_reinforce.lab.seed.presets import seed_hyperparams
from sb3_reinforce.lab.seed.reproduction import main as seed_main
from sb3_reinforce.lab.seed.summary import stopped_reason


class _ImageEnv(gym.Env[np.ndarray, np.ndarray]):
    """Returns one fixed RGB image and records the actions it is given."""

    def __init__(self, image: np.ndarray) -> None:
        self.image = image
        self.observation_space = spaces.Box(0, 255, image.shape, np.uint8)
        self.action_space = spaces.Box(np.array([-1, 0, 0], np.float32), np.array([1, 1, 1], np.float32), dtype=np.float32)
        self.actions: list[np.ndarray] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        return self.image, {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.actions.append(np.asarray(action))
        return self.image, 0.0, False, False, {}


def _wrappers(env: gym.Env) -> list[type]:
    found = []
    while isinstance(env, gym.Wrapper):
        found.append(type(env))
        env = env.env
    return found


def test_seed_pixels_are_the_scripts_grayscale_every_second_pixel() -> None:
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, size=(96, 96, 3), dtype=np.uint8)
    env = SeedPixels(_ImageEnv(image))
    obs, _ = env.reset()
    # the seed's script, written out: luma weights, then [::2, ::2], then ravel
    expected = np.array(
        [
            [0.299 * image[r, c, 0] + 0.587 * image[r, c, 1] + 0.114 * image[r, c, 2] for c in range(0, 96, 2)]
            for r in range(0, 96, 2)
        ]
    ).ravel()
    assert obs.shape == (2304,) and obs.dtype == np.float32 and env.observation_space.shape == (2304,)
    np.testing.assert_allclose(obs, expected, rtol=1e-6)
    assert env.observation_space.contains(obs)
    with pytest.raises(ValueError, match="RGB"):
        SeedPixels(gym.make("CartPole-v1"))


def test_one_hot_actions_set_one_dimension() -> None:
    inner = _ImageEnv(np.zeros((4, 4, 3), dtype=np.uint8))
    env = OneHotActions(inner)
    assert env.action_space == spaces.Discrete(3)
    env.reset()
    for action in (0, 1, 2):
        env.step(action)
    np.testing.assert_array_equal(np.stack(inner.actions), np.eye(3))
    with pytest.raises(ValueError, match="Box"):
        OneHotActions(gym.make("CartPole-v1"))


def test_make_seed_env_time_limits() -> None:
    car = make_seed_env("CarRacing-v3")
    assert _wrappers(car)[:3] == [OneHotActions, SeedPixels, gym.wrappers.TimeLimit]
    assert car.spec is not None and car.spec.max_episode_steps == 502
    assert car.observation_space.shape == (2304,) and car.action_space == spaces.Discrete(3)
    car.close()
    mountain = make_seed_env("MountainCar-v0")
    assert gym.wrappers.TimeLimit not in _wrappers(mountain)
    mountain.reset(seed=0)
    for _ in range(300):  # past the registered 200 steps: pushing right alone never reaches the flag
        _, _, terminated, truncated, _ = mountain.step(2)
        assert not (terminated or truncated)
    lander = make_seed_env("LunarLander-v3")
    assert lander.spec is not None and lander.spec.max_episode_steps == 1000


def test_carracing_preset_is_the_layers_network() -> None:
    kwargs = seed_hyperparams("CarRacing-v3")
    assert kwargs["learning_rate"] == 0.01 and kwargs["gamma"] == 0.95
    model = REINFORCE(env=make_seed_env("CarRacing-v3"), seed=0, **kwargs)
    linears = [m for m in model.policy.modules() if isinstance(m, th.nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(2304, 10), (10, 10), (10, 3)]
    for m in linears:
        assert th.all(m.bias == 0.1)
    first = linears[0].weight
    assert abs(first.mean().item()) < 0.01 and first.std().item() == pytest.approx(0.3, rel=0.03)
    # the optimizer was built after the initialization: it holds the initialized parameters
    assert {id(p) for g in model.policy.optimizer.param_groups for p in g["params"]} == {
        id(p) for p in model.policy.parameters()
    }


def test_normal_init_round_trip_and_errors(tmp_path: Path) -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", policy_kwargs=dict(normal_init=(0.5, -0.2)), seed=0)
    assert th.all(model.policy.action_net.bias == -0.2)
    model.save(tmp_path / "model")
    loaded = REINFORCE.load(tmp_path / "model")
    assert loaded.policy.normal_init == (0.5, -0.2)
    for a, b in zip(model.policy.parameters(), loaded.policy.parameters(), strict=True):
        assert th.equal(a, b)
    with pytest.raises(ValueError, match="not both"):
        REINFORCE("MlpPolicy", "CartPole-v1", policy_kwargs=dict(normal_init=(0.3, 0.1), xavier_init=True))
    for bad in [(0.0, 0.1), (float("nan"), 0.1), (0.3,), 0.3, ("a", "b")]:
        with pytest.raises(ValueError, match="normal_init"):
            REINFORCE("MlpPolicy", "CartPole-v1", policy_kwargs=dict(normal_init=bad))


def test_seed_run_stops_at_the_step_cap_and_counts_as_done(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["--env", "CartPole-v1", "--episodes", "1000", "--seeds", "1", "--workers", "1", "--max-steps", "100"]
    seed_main([*args, "--out", str(tmp_path)])
    stopped = stopped_reason(tmp_path / "episodes_seed0.stopped")
    episodes = pd.read_csv(tmp_path / "episodes.csv")
    assert 0 < len(episodes) < 1000 and episodes["steps"].iloc[-1] >= 100
    assert (
        stopped
        == f"seed 0 stopped after {len(episodes)} of 1,000 episodes: the step cap of 100 steps (--max-steps) was reached"
    )
    assert f"- {stopped}" in (tmp_path / "summary.md").read_text()
    capsys.readouterr()
    seed_main([*args, "--out", str(tmp_path)])  # done under the same settings: skipped, not started over
    assert "0 seed(s) trained, 1 already done" in capsys.readouterr().out
    assert len(pd.read_csv(tmp_path / "episodes.csv")) == len(episodes)
    seed_main([*args[:-1], "300", "--out", str(tmp_path)])  # a larger cap: trained again
    assert "1 seed(s) trained, 0 already done" in capsys.readouterr().out
    assert pd.read_csv(tmp_path / "episodes.csv")["steps"].iloc[-1] >= 300


def test_seed_run_stops_an_episode_that_never_ends(tmp_path: Path) -> None:
    # MountainCar without a time limit: the first episode of a random policy runs far past 300 steps
    args = ["--env", "MountainCar-v0", "--episodes", "3", "--seeds", "1", "--workers", "1", "--max-episode-steps", "300"]
    seed_main([*args, "--out", str(tmp_path)])
    stopped = stopped_reason(tmp_path / "episodes_seed0.stopped")
    assert stopped == "seed 0 stopped after 0 of 3 episodes: episode 1 did not end within 300 steps (--max-episode-steps)"
    assert "No training episode finished." in (tmp_path / "summary.md").read_text()
