"""
The return math of REINFORCE::

    G_t = sum_{k=0}^{T-t-1} gamma^k * r_{t+k}        (reward-to-go, restarted at every episode end)
    G_t = r_t + gamma * G_{t+1},  G_T = 0            (computed so, by scipy's lfilter: no gamma^t underflow)
    G_norm_t = (G_t - mean(G)) / (std(G) + eps)      (over the whole batch, population std)
    b_loo(i, t) = mean_{j != i, T_j > t} G^j_t        (leave-one-out baseline, 0 where no other episode lasted)
"""

import numpy as np
import torch as th
from scipy.signal import lfilter

__all__ = ["discounted_returns", "episode_bounds", "leave_one_out_baseline", "normalize_returns"]


def _discount_cumsum(rewards: np.ndarray, gamma: float) -> np.ndarray:
    # y[n] = x[n] + gamma * y[n - 1] on the reversed sequence, i.e. G_t = r_t + gamma * G_{t+1}
    return np.ascontiguousarray(lfilter([1.0], [1.0, -float(gamma)], rewards[::-1])[::-1])


def episode_bounds(episode_ends: np.ndarray) -> list[tuple[int, int]]:
    """
    Split a flat sequence of steps into episodes.

    :param episode_ends: Boolean array, True on the last step of each episode.
        Steps after the last ``True`` form a final (unfinished) segment.
    :return: ``(start, stop)`` index pairs, one per episode, covering every step once and in order.
    """
    n_steps = len(episode_ends)
    stops = (np.flatnonzero(episode_ends) + 1).tolist()
    if not stops or stops[-1] != n_steps:
        stops.append(n_steps)
    starts = [0, *stops[:-1]]
    return [(start, stop) for start, stop in zip(starts, stops, strict=True) if stop > start]


def discounted_returns(rewards: np.ndarray, gamma: float, episode_ends: np.ndarray | None = None) -> np.ndarray:
    """
    Discounted reward-to-go ``G_t = sum_k gamma^k r_{t+k}``, computed separately within each episode.

    :param rewards: Rewards of consecutive steps, shape ``(n_steps,)``.
    :param gamma: Discount factor in [0, 1].
    :param episode_ends: Boolean array of shape ``(n_steps,)``, True on the last step of each episode
        (the return does not flow across it). ``None`` means the whole sequence is one episode.
    :return: The returns, float64, shape ``(n_steps,)``.
    """
    rewards = np.asarray(rewards, dtype=np.float64)
    if rewards.ndim != 1:
        raise ValueError(f"rewards must be one-dimensional, got shape {rewards.shape}")
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma must be in [0, 1], got {gamma}")
    if episode_ends is None:
        return _discount_cumsum(rewards, gamma) if len(rewards) else rewards.copy()
    episode_ends = np.asarray(episode_ends, dtype=bool)
    if episode_ends.shape != rewards.shape:
        raise ValueError(f"episode_ends has shape {episode_ends.shape}, rewards {rewards.shape}: they must match")
    returns = np.empty_like(rewards)
    for start, stop in episode_bounds(episode_ends):
        returns[start:stop] = _discount_cumsum(rewards[start:stop], gamma)
    return returns


def normalize_returns(returns: th.Tensor, eps: float = 1e-8) -> th.Tensor:
    """
    Standardize over the batch: ``(G - mean(G)) / (std(G) + eps)``, population std as in ``np.std``.
    Equal values (e.g. one-step episodes with the same reward) give all zeros, never NaN.

    :param returns: Returns (or advantages), any shape.
    :param eps: Added to the std to keep the division finite.
    :return: Tensor of the same shape, mean 0 and std 1 (up to ``eps``).
    """
    centered = returns - returns.mean()
    return centered / (centered.pow(2).mean().sqrt() + eps)


def leave_one_out_baseline(returns: np.ndarray, episode_lengths: np.ndarray) -> np.ndarray:
    """
    Critic-free leave-one-out baseline (RLOO's, with the time index standing in for the state)::

        b(i, t) = sum_{j != i, T_j > t} G^j_t / #{j != i : T_j > t}      (0 when no other episode reached step t)

    Episodes are sampled independently, so ``b(i, t)`` ignores episode ``i``'s actions and ``G - b`` stays unbiased.

    :param returns: The batch's returns ``G``, episode after episode, shape ``(n_steps,)``
    :param episode_lengths: Length of each episode, in order (summing to ``n_steps``)
    :return: The baseline, float64, shape ``(n_steps,)``
    """
    returns = np.asarray(returns, dtype=np.float64)
    episode_lengths = np.asarray(episode_lengths, dtype=np.int64)
    if returns.ndim != 1 or episode_lengths.sum() != len(returns):
        raise ValueError(f"episode_lengths sum to {episode_lengths.sum()}, but there are {len(returns)} returns")
    # Time index of every step within its episode: 0, ..., T_i - 1
    starts = np.repeat(np.cumsum(episode_lengths) - episode_lengths, episode_lengths)
    time_index = np.arange(len(returns)) - starts
    totals = np.bincount(time_index, weights=returns)[time_index]  # sum over every episode at step t
    others = np.bincount(time_index)[time_index] - 1  # episodes other than this one at step t
    return np.where(others > 0, (totals - returns) / np.maximum(others, 1), 0.0)
