"""REINFORCE (Monte-Carlo policy gradient) as a native Stable-Baselines3 algorithm."""

from sb3_reinforce.reinforce import *  # noqa: F403  (the algorithm's API is the package's, as sb3-contrib's)
from sb3_reinforce.reinforce import __all__ as _ALGORITHM_API
from sb3_reinforce.version import __version__

__all__ = [*_ALGORITHM_API, "__version__"]
