"""
The algorithm: REINFORCE, its policies, its whole-episode rollout buffers, the return math, the fast action
sampler, and the two save formats (SB3's ``.zip`` and the weights-only file). Nothing here imports the tooling
(:mod:`sb3_reinforce.lab`).
"""

from sb3_reinforce.reinforce.buffers import (
    DictEpisodeRolloutBuffer,
    DictEpisodeRolloutBufferSamples,
    EpisodeRolloutBuffer,
    EpisodeRolloutBufferSamples,
    RolloutLimitError,
)
from sb3_reinforce.reinforce.finite_checks import NonFiniteError
from sb3_reinforce.reinforce.model_file import CorruptModelFileError
from sb3_reinforce.reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy, ReinforcePolicy
from sb3_reinforce.reinforce.reinforce import REINFORCE
from sb3_reinforce.reinforce.returns import discounted_returns, normalize_returns
from sb3_reinforce.reinforce.weights_only import UnsafeFileError, load_weights, save_weights

__all__ = [
    "REINFORCE",
    "CnnPolicy",
    "CorruptModelFileError",
    "DictEpisodeRolloutBuffer",
    "DictEpisodeRolloutBufferSamples",
    "EpisodeRolloutBuffer",
    "EpisodeRolloutBufferSamples",
    "MlpPolicy",
    "MultiInputPolicy",
    "NonFiniteError",
    "ReinforcePolicy",
    "RolloutLimitError",
    "UnsafeFileError",
    "discounted_returns",
    "load_weights",
    "normalize_returns",
    "save_weights",
]
