"""Bad input fails before training with an error naming the parameter; numerical trouble never reaches the weights."""

import math

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards import CheckFinite, NonFiniteError
from tests.envs import CountingEnv


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(gamma=1.5), "gamma"),
        (dict(gamma=-0.1), "gamma"),
        (dict(gamma=math.nan), "gamma"),
        (dict(n_episodes=0), "n_episodes"),
        (dict(n_episodes=2.5), "n_episodes"),
        (dict(n_episodes=True), "n_episodes"),
        (dict(min_steps=-1), "min_steps"),
        (dict(learning_rate=-1e-3), "learning_rate"),
        (dict(learning_rate=math.inf), "learning_rate"),
        (dict(learning_rate="0.1"), "learning_rate"),
        (dict(ent_coef=-0.01), "ent_coef"),
        (dict(vf_coef=-1.0), "vf_coef"),
        (dict(max_grad_norm=0.0), "max_grad_norm"),
        (dict(max_grad_norm=-1.0), "max_grad_norm"),
        (dict(baseline="critic"), "baseline"),
        (dict(baseline=True), "baseline"),
        (dict(normalize_returns="yes"), "normalize_returns"),
        (dict(max_rollout_steps=0), "max_rollout_steps"),
        (dict(min_steps=10, max_rollout_steps=5), "min_steps"),
        (dict(policy_kwargs=dict(value_head=True)), "value_head"),
    ],
)
def test_bad_hyperparameters(kwargs: dict, name: str) -> None:
    # An unregistered env id: the arguments must be checked before anything (env included) is built.
    with pytest.raises(ValueError, match=name) as info:
        REINFORCE("MlpPolicy", "NoSuchEnv-v0", **kwargs)
    if name == "baseline":
        assert "'value'" in str(info.value), "the error lists the allowed values"


def test_valid_edge_values() -> None:
    for kwargs in (dict(gamma=0.0), dict(gamma=1.0), dict(max_grad_norm=None), dict(learning_rate=lambda _: 1e-3)):
        model = REINFORCE("MlpPolicy", "CartPole-v1", **kwargs).learn(50)
        assert model.num_timesteps >= 50
        assert all(getattr(model, name) == value for name, value in kwargs.items())  # kept as given


class BrokenEnv(CountingEnv):
    def __init__(self, what: str, when: int = 5):
        super().__init__(0, (1000,))
        self.what, self.when = what, when

    def step(self, action: int) -> tuple:
        obs, reward, terminated, truncated, info = super().step(action)
        if self.t == self.when:
            if self.what == "reward":
                reward = math.nan
            elif self.what == "obs":
                obs = obs.copy()
                obs[1] = math.inf
        return obs, reward, terminated, truncated, info


@pytest.mark.parametrize("what", ["reward", "obs"])
@pytest.mark.parametrize("check_finite", [True, False])
def test_non_finite_env_output_raises(what: str, check_finite: bool) -> None:
    # With CheckFinite, the error names the env and the step it came from; without it, REINFORCE refuses the
    # non-finite gradient it makes. The weights are unchanged either way.
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: BrokenEnv(what)]), seed=0)
    before = [p.detach().clone() for p in model.policy.parameters()]
    if check_finite:
        with pytest.raises(NonFiniteError, match=f"Environment 0 returned a non-finite {what.replace('obs', 'observation')}"):
            model.learn(2000, callback=CheckFinite())
    else:
        # named as the environment's output, before any advice about learning rates (issue 62)
        named = f"The environment returned a non-finite {what.replace('obs', 'observation')}"
        with pytest.raises(FloatingPointError, match=f"{named} .*weights are unchanged. Check the environment"):
            model.learn(2000)
    assert all(th.equal(a, b) for a, b in zip(before, model.policy.parameters(), strict=True))


def _check_step(new_obs: object, rewards: np.ndarray) -> None:
    callback = CheckFinite()
    callback.init_callback(REINFORCE("MlpPolicy", "CartPole-v1"))
    callback.update_locals({"new_obs": new_obs, "rewards": rewards, "infos": [{} for _ in rewards]})
    callback.on_step()


def test_finite_but_huge_env_output_is_accepted() -> None:
    # The finite check sums each step's rewards and observations first: sums that overflow to inf must not be
    # taken for a NaN/inf (the exact check after them finds every value finite).
    huge_obs, huge_rewards = np.full((2, 4), 3e38, dtype=np.float32), np.full(2, 1.7e308)
    assert not np.isfinite(huge_obs.sum()) and not np.isfinite(huge_rewards.sum())  # the sums overflow
    _check_step(huge_obs, huge_rewards)  # no error
    _check_step({"a": huge_obs, "b": np.zeros((2, 1), dtype=np.uint8)}, huge_rewards)
    # Control: one NaN among the huge values is found
    huge_obs[1, 2] = math.nan
    with pytest.raises(NonFiniteError, match="Environment 1 returned a non-finite observation"):
        _check_step(huge_obs, huge_rewards)
    with pytest.raises(NonFiniteError, match="key 'a'"):
        _check_step({"a": huge_obs, "b": np.zeros((2, 1), dtype=np.uint8)}, huge_rewards)


def test_overflowing_loss_leaves_weights_unchanged() -> None:
    class HugeReward(CountingEnv):
        def step(self, action: int) -> tuple:
            obs, _, terminated, truncated, info = super().step(action)
            return obs, 3e38, terminated, truncated, info  # finite, but returns overflow float32

    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: HugeReward(0, (20,))]), normalize_returns=False, seed=0)
    before = [p.detach().clone() for p in model.policy.parameters()]
    with pytest.raises(FloatingPointError, match="weights are unchanged"):
        model.learn(100)
    assert all(th.equal(a, b) for a, b in zip(before, model.policy.parameters(), strict=True))


def test_zero_variance_returns_stay_finite() -> None:
    # One-step episodes with equal rewards: every standardized return is 0, no NaN.
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: CountingEnv(0, (1,))]), n_episodes=3, seed=0).learn(60)
    assert all(np.isfinite(p.detach().numpy()).all() for p in model.policy.parameters())
