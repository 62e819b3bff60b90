"""
Fuzzing: hypothesis-generated environments run through ``learn()``: they train with finite parameters,
or raise the documented error when the environment emits NaN/inf (``NonFiniteError`` from the ``CheckFinite``
callback; without it, REINFORCE's ``FloatingPointError`` at the update, the weights unchanged).

CI runs ``SB3_REINFORCE_FUZZ_EXAMPLES`` examples (default 30, derandomized so CI is reproducible). For a longer
random campaign:
``SB3_REINFORCE_FUZZ_EXAMPLES=500 python -m pytest tests/algorithm/test_fuzz.py --hypothesis-show-statistics``.
"""

import math
import os
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards import CheckFinite, NonFiniteError

N_EXAMPLES = int(os.environ.get("SB3_REINFORCE_FUZZ_EXAMPLES", "30"))


def box(draw: st.DrawFn, action: bool) -> spaces.Box:
    shape = tuple(draw(st.lists(st.integers(1, 3), min_size=1, max_size=1 if action else 2)))
    dtype = draw(st.sampled_from([np.float32, np.float64]))
    if not action and draw(st.booleans()):
        return spaces.Box(-np.inf, np.inf, shape=shape, dtype=dtype)
    low = draw(st.floats(-10, 0, allow_nan=False, allow_infinity=False))
    return spaces.Box(low, low + draw(st.floats(0.1, 10)), shape=shape, dtype=dtype)


def space(draw: st.DrawFn, action: bool) -> spaces.Space:
    """A supported observation (``action=False``, Dict included) or action space."""
    kind = draw(st.sampled_from(["box", "discrete", "multidiscrete", "multibinary", *([] if action else ["dict"])]))
    if kind == "box":
        return box(draw, action=action)
    if kind == "discrete":
        return spaces.Discrete(draw(st.integers(1, 5)))
    if kind == "multidiscrete":
        return spaces.MultiDiscrete(draw(st.lists(st.integers(1, 4), min_size=1, max_size=3)))
    if kind == "multibinary":
        return spaces.MultiBinary(draw(st.integers(1, 3 if action else 4)))
    return spaces.Dict({"a": box(draw, action=False), "b": spaces.Discrete(draw(st.integers(1, 4)))})


@st.composite
def observation_spaces(draw: st.DrawFn) -> spaces.Space:
    return space(draw, action=False)


@st.composite
def action_spaces(draw: st.DrawFn) -> spaces.Space:
    return space(draw, action=True)


class FuzzEnv(gym.Env):
    """Episode lengths cycle through ``lengths``; rewards ``scale * N(0, 1)``; optional NaN/inf at one step."""

    def __init__(self, obs_space: spaces.Space, action_space: spaces.Space, cfg: dict[str, Any], env_idx: int):
        self.observation_space, self.action_space, self.cfg = obs_space, action_space, cfg
        self.env_idx = env_idx
        self.rng = np.random.default_rng(cfg["seed"] + env_idx)
        self.observation_space.seed(cfg["seed"] + env_idx)
        self.n_episodes, self.t, self.total_steps = 0, 0, 0
        self.injected: str | None = None  # what got the NaN/inf: "reward", "obs" or "terminal_obs"

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.length = self.cfg["lengths"][self.n_episodes % len(self.cfg["lengths"])]
        self.n_episodes += 1
        self.t = 0
        return self.observation_space.sample(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        assert self.action_space.contains(np.asarray(action, dtype=self.action_space.dtype)), action
        self.t += 1
        self.total_steps += 1
        obs = self.observation_space.sample()
        reward = self.cfg["scale"] * float(self.rng.standard_normal())
        done = self.t >= self.length
        if self.env_idx == 0 and self.total_steps == self.cfg["inject_at"] and self.cfg["inject"] is not None:
            target = obs["a"] if isinstance(obs, dict) else obs
            if self.cfg["inject"] == "obs" and isinstance(target, np.ndarray) and target.dtype.kind == "f":
                target.flat[0] = math.inf  # the VecEnv passes it on, or keeps it as info["terminal_observation"]
                self.injected = "terminal_obs" if done else "obs"
            else:
                reward = math.nan
                self.injected = "reward"
        truncated = done and self.cfg["truncate"]
        return obs, reward, done and not truncated, truncated, {}


@st.composite
def configs(draw: st.DrawFn) -> tuple[spaces.Space, spaces.Space, dict[str, Any], dict[str, Any]]:
    obs_space = draw(observation_spaces())
    action_space = draw(action_spaces())
    cfg = dict(
        seed=draw(st.integers(0, 2**16)),
        lengths=draw(st.lists(st.integers(1, 30), min_size=1, max_size=4)),
        scale=draw(st.sampled_from([1.0, -1.0])) * 10.0 ** draw(st.integers(-8, 8)),
        truncate=draw(st.booleans()),
        inject=draw(st.sampled_from([None, None, "reward", "obs"])),
        inject_at=draw(st.integers(1, 80)),
        n_envs=draw(st.integers(1, 3)),
    )
    hyper = dict(
        baseline=draw(st.sampled_from([None, "value"])),
        normalize_returns=draw(st.booleans()),
        gamma=draw(st.sampled_from([0.0, 0.5, 0.99, 1.0])),
        n_episodes=draw(st.integers(1, 3)),
        min_steps=draw(st.integers(0, 20)),
        ent_coef=draw(st.sampled_from([0.0, 0.01])),
        max_grad_norm=draw(st.sampled_from([None, 0.5])),
    )
    return obs_space, action_space, cfg, hyper


FUZZ = settings(
    max_examples=N_EXAMPLES,
    deadline=None,
    derandomize="SB3_REINFORCE_FUZZ_EXAMPLES" not in os.environ,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
Config = tuple[spaces.Space, spaces.Space, dict[str, Any], dict[str, Any]]


def build(config: Config) -> tuple[DummyVecEnv, REINFORCE]:
    """The generated environments and a small REINFORCE on them."""
    obs_space, action_space, cfg, hyper = config
    venv = DummyVecEnv([lambda i=i: FuzzEnv(obs_space, action_space, cfg, i) for i in range(cfg["n_envs"])])
    policy = "MultiInputPolicy" if isinstance(obs_space, spaces.Dict) else "MlpPolicy"
    return venv, REINFORCE(policy, venv, policy_kwargs=dict(net_arch=[8]), seed=cfg["seed"], **hyper)


@FUZZ
@given(configs())
def test_fuzz_learn(config: Config) -> None:
    _, _, cfg, hyper = config
    venv, model = build(config)
    try:
        model.learn(100, callback=CheckFinite())
    except NonFiniteError as error:
        # The documented error, and only for the env's NaN/inf (the rewards go up to 30 * 1e8: no overflow)
        injected = venv.envs[0].injected  # type: ignore[attr-defined]
        assert injected is not None, f"NonFiniteError without a NaN/inf from the env: {error}"
        assert "Environment 0 returned a non-finite" in str(error)
        assert all(th.isfinite(p).all() for p in model.policy.parameters())
        return
    # A terminal observation is read only to bootstrap a truncated episode with a value baseline
    injected = venv.envs[0].injected  # type: ignore[attr-defined]
    used = injected in ("reward", "obs") or (injected == "terminal_obs" and cfg["truncate"] and hyper["baseline"] == "value")
    assert not used, f"a NaN/inf ({injected}) from the env went unnoticed"
    assert model.num_timesteps >= 100 and model._n_updates >= 1
    assert all(th.isfinite(p).all() for p in model.policy.parameters())


@FUZZ
@given(configs())
def test_fuzz_learn_without_check(config: Config) -> None:
    # Without CheckFinite, a NaN/inf the env emits is refused by REINFORCE itself at the update it would spoil
    # (a FloatingPointError, the weights unchanged), or is never used: the weights stay finite either way.
    venv, model = build(config)
    try:
        model.learn(100)
    except FloatingPointError as error:
        assert venv.envs[0].injected is not None, f"a non-finite update without a NaN/inf from the env: {error}"  # type: ignore[attr-defined]
        assert "weights are unchanged" in str(error)
    assert all(th.isfinite(p).all() for p in model.policy.parameters())
