"""REINFORCE (Monte-Carlo policy gradient) as a native Stable-Baselines3 algorithm."""

from sb3_reinforce.buffers import (
    DictEpisodeRolloutBuffer,
    DictEpisodeRolloutBufferSamples,
    EpisodeRolloutBuffer,
    EpisodeRolloutBufferSamples,
    RolloutLimitError,
)
from sb3_reinforce.env_errors import EnvError, EnvWorkerDiedError, make_safe_vec_env
from sb3_reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy
from sb3_reinforce.presets import seed_hyperparams
from sb3_reinforce.reinforce import REINFORCE, NonFiniteError
from sb3_reinforce.returns import discounted_returns, normalize_returns
from sb3_reinforce.safe_io import CorruptModelFileError, UnsafeFileError, load_weights, save_weights
from sb3_reinforce.version import __version__

__all__ = [
    "REINFORCE",
    "CnnPolicy",
    "CorruptModelFileError",
    "DictEpisodeRolloutBuffer",
    "DictEpisodeRolloutBufferSamples",
    "EnvError",
    "EnvWorkerDiedError",
    "EpisodeRolloutBuffer",
    "EpisodeRolloutBufferSamples",
    "MlpPolicy",
    "MultiInputPolicy",
    "NonFiniteError",
    "RolloutLimitError",
    "UnsafeFileError",
    "__version__",
    "discounted_returns",
    "load_weights",
    "make_safe_vec_env",
    "normalize_returns",
    "save_weights",
    "seed_hyperparams",
]
