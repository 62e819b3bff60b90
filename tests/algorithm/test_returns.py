"""Property-based tests of the return math against a plain-Python reference."""

import numpy as np
import pytest
import torch as th
from hypothesis import given, settings
from hypothesis import strategies as st

from sb3_reinforce import discounted_returns, normalize_returns
from sb3_reinforce.reinforce.returns import episode_bounds


def reference_returns(rewards: list[float], ends: list[bool], gamma: float) -> list[float]:
    """G_t = sum_k gamma^k r_{t+k} within the episode, written the slow, obvious way."""
    returns = []
    for t in range(len(rewards)):
        total, discount = 0.0, 1.0
        for k in range(t, len(rewards)):
            total += discount * rewards[k]
            discount *= gamma
            if ends[k]:
                break
        returns.append(total)
    return returns


rewards_st = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)
gammas = st.one_of(st.just(0.0), st.just(1.0), st.floats(min_value=0.0, max_value=1.0))


@st.composite
def episodes(draw: st.DrawFn) -> tuple[list[float], list[bool]]:
    n = draw(st.integers(min_value=1, max_value=60))
    rewards = draw(st.lists(rewards_st, min_size=n, max_size=n))
    ends = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    return rewards, ends


@settings(max_examples=300, deadline=None)
@given(data=episodes(), gamma=gammas)
def test_discounted_returns_match_reference(data: tuple[list[float], list[bool]], gamma: float) -> None:
    rewards, ends = data
    expected = reference_returns(rewards, ends, gamma)
    got = discounted_returns(np.array(rewards), gamma, np.array(ends))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * (1 + max(abs(r) for r in rewards)) * len(rewards))


@settings(max_examples=100, deadline=None)
@given(data=episodes(), gamma=gammas)
def test_returns_do_not_cross_episode_ends(data: tuple[list[float], list[bool]], gamma: float) -> None:
    rewards, ends = data
    got = discounted_returns(np.array(rewards), gamma, np.array(ends))
    for start, stop in episode_bounds(np.array(ends)):
        alone = discounted_returns(np.array(rewards[start:stop]), gamma)
        np.testing.assert_allclose(got[start:stop], alone, rtol=1e-12, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(ends=st.lists(st.booleans(), min_size=0, max_size=50))
def test_episode_bounds_cover_every_step_once(ends: list[bool]) -> None:
    bounds = episode_bounds(np.array(ends, dtype=bool))
    covered = [i for start, stop in bounds for i in range(start, stop)]
    assert covered == list(range(len(ends)))
    for start, stop in bounds:
        assert not any(ends[start : stop - 1]), "an episode end inside a segment"


def test_closed_forms() -> None:
    rewards = np.ones(5)
    np.testing.assert_allclose(discounted_returns(rewards, 1.0), [5, 4, 3, 2, 1])
    np.testing.assert_allclose(discounted_returns(rewards, 0.0), rewards)
    np.testing.assert_allclose(discounted_returns(rewards, 0.5), [1.9375, 1.875, 1.75, 1.5, 1.0])
    ends = np.array([False, True, False, False, True])
    np.testing.assert_allclose(discounted_returns(rewards, 1.0, ends), [2, 1, 3, 2, 1])


def test_long_episode_is_stable() -> None:
    # 200k steps with gamma < 1: closed forms with gamma^t underflow here; the recursion does not.
    rewards = np.full(200_000, -1.0)
    returns = discounted_returns(rewards, 0.99)
    assert np.isfinite(returns).all()
    np.testing.assert_allclose(returns[0], -(1 - 0.99**200_000) / (1 - 0.99))
    np.testing.assert_allclose(returns[-1], -1.0)


def test_extreme_reward_scales() -> None:
    for scale in (1e-8, 1e8):
        returns = discounted_returns(np.full(1000, scale), 0.999)
        assert np.isfinite(returns).all()
        normalized = normalize_returns(th.as_tensor(returns, dtype=th.float32))
        assert th.isfinite(normalized).all()
        assert abs(normalized.mean().item()) < 1e-4


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="gamma"):
        discounted_returns(np.ones(3), 1.5)
    with pytest.raises(ValueError, match="episode_ends"):
        discounted_returns(np.ones(3), 0.9, np.ones(2, dtype=bool))


@settings(max_examples=200, deadline=None)
@given(values=st.lists(rewards_st, min_size=1, max_size=100))
def test_normalize_returns(values: list[float]) -> None:
    x = th.tensor(values, dtype=th.float64)
    z = normalize_returns(x)
    assert th.isfinite(z).all()
    std = np.std(values)  # population std, as the seed's np.std
    expected = (np.array(values) - np.mean(values)) / (std + 1e-8)
    np.testing.assert_allclose(z.numpy(), expected, rtol=1e-6, atol=1e-6)


def test_normalize_zero_variance_gives_zeros() -> None:
    for x in (th.tensor([3.0]), th.full((7,), -2.5)):
        z = normalize_returns(x)
        assert th.equal(z, th.zeros_like(x))


def test_normalize_matches_seed_per_episode_standardization() -> None:
    # The seed: discounted_episode_rewards -= mean; /= std (one episode per batch).
    rewards = np.array([1.0, -2.0, 0.5, 3.0, -1.0])
    seed_returns = discounted_returns(rewards, 0.99)
    seed_returns = (seed_returns - np.mean(seed_returns)) / np.std(seed_returns)
    ours = normalize_returns(th.as_tensor(discounted_returns(rewards, 0.99)))
    np.testing.assert_allclose(ours.numpy(), seed_returns, rtol=1e-6)
