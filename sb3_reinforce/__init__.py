"""REINFORCE (Monte-Carlo policy gradient) as a native Stable-Baselines3 algorithm."""

from sb3_reinforce.buffers import (
    DictEpisodeRolloutBuffer,
    DictEpisodeRolloutBufferSamples,
    EpisodeRolloutBuffer,
    EpisodeRolloutBufferSamples,
    RolloutLimitError,
)
from sb3_reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy
from sb3_reinforce.presets import seed_hyperparams
from sb3_reinforce.reinforce import REINFORCE, NonFiniteError
from sb3_reinforce.returns import discounted_returns, normalize_returns
from sb3_reinforce.version import __version__

__all__ = [
    "REINFORCE",
    "CnnPolicy",
    "DictEpisodeRolloutBuffer",
    "DictEpisodeRolloutBufferSamples",
    "EpisodeRolloutBuffer",
    "EpisodeRolloutBufferSamples",
    "MlpPolicy",
    "MultiInputPolicy",
    "NonFiniteError",
    "RolloutLimitError",
    "__version__",
    "discounted_returns",
    "normalize_returns",
    "seed_hyperparams",
]
