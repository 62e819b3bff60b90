"""REINFORCE, its policies, its whole-episode rollout buffers and the return math."""

from sb3_reinforce.reinforce.buffers import (
    DictEpisodeRolloutBuffer,
    DictEpisodeRolloutBufferSamples,
    EpisodeRolloutBuffer,
    EpisodeRolloutBufferSamples,
    RolloutLimitError,
)
from sb3_reinforce.reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy, ReinforcePolicy
from sb3_reinforce.reinforce.reinforce import REINFORCE
from sb3_reinforce.reinforce.returns import discounted_returns, normalize_returns

__all__ = [
    "REINFORCE",
    "CnnPolicy",
    "DictEpisodeRolloutBuffer",
    "DictEpisodeRolloutBufferSamples",
    "EpisodeRolloutBuffer",
    "EpisodeRolloutBufferSamples",
    "MlpPolicy",
    "MultiInputPolicy",
    "ReinforcePolicy",
    "RolloutLimitError",
    "discounted_returns",
    "normalize_returns",
]
