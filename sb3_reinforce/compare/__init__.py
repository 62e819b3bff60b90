"""The comparison of REINFORCE with PPO and A2C: ``sb3-reinforce compare`` / ``python -m sb3_reinforce.compare``."""

from sb3_reinforce.compare.cli import main
from sb3_reinforce.compare.hyperparams import ALGOS, ZooConfig, ZooConfigError, load_zoo_config
from sb3_reinforce.compare.runner import RESULT_COLUMNS, RunSpec, run

__all__ = ["ALGOS", "RESULT_COLUMNS", "RunSpec", "ZooConfig", "ZooConfigError", "load_zoo_config", "main", "run"]
