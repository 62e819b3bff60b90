"""
Opt-in safeguards beyond SB3 and sb3-contrib, outside the algorithm: loading an untrusted file without unpickling
anything (the weights-only format, REINFORCE's), a clear error naming the environment and step of a NaN or an inf,
random-stream continuation after a load, returning freed heap memory during long runs, and VecEnvs that say which
environment failed and why (all but the first for any SB3 algorithm). Nothing in :mod:`sb3_reinforce.reinforce`
imports this package.
"""

from sb3_reinforce.safeguards.callbacks import CheckFinite, NonFiniteError, TrimHeap
from sb3_reinforce.safeguards.env_errors import EnvError, EnvWorkerDiedError, make_safe_vec_env
from sb3_reinforce.safeguards.random_state import load_with_random_state, save_with_random_state
from sb3_reinforce.safeguards.weights_only import CorruptModelFileError, UnsafeFileError, load_weights, save_weights

__all__ = [
    "CheckFinite",
    "CorruptModelFileError",
    "EnvError",
    "EnvWorkerDiedError",
    "NonFiniteError",
    "TrimHeap",
    "UnsafeFileError",
    "load_weights",
    "load_with_random_state",
    "make_safe_vec_env",
    "save_weights",
    "save_with_random_state",
]
