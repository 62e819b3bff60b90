"""REINFORCE (Monte-Carlo policy gradient) as a native Stable-Baselines3 algorithm."""

from sb3_reinforce.reinforce import (
    REINFORCE,
    CnnPolicy,
    CorruptModelFileError,
    DictEpisodeRolloutBuffer,
    DictEpisodeRolloutBufferSamples,
    EpisodeRolloutBuffer,
    EpisodeRolloutBufferSamples,
    MlpPolicy,
    MultiInputPolicy,
    NonFiniteError,
    ReinforcePolicy,
    RolloutLimitError,
    UnsafeFileError,
    discounted_returns,
    load_weights,
    normalize_returns,
    save_weights,
)
from sb3_reinforce.version import __version__

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
    "__version__",
    "discounted_returns",
    "load_weights",
    "normalize_returns",
    "save_weights",
]
