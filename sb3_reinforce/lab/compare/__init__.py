"""The comparison of REINFORCE with PPO and A2C: ``sb3-reinforce compare`` / ``python -m sb3_reinforce.lab.compare``."""

from sb3_reinforce.lab.compare.command import main
from sb3_reinforce.lab.compare.experiment import DEFAULT_ALGOS, ZooEntry, build_run, known_algos, read_entry
from sb3_reinforce.lab.compare.folder import RESULT_COLUMNS, ComparisonFolder, RunSpec
from sb3_reinforce.lab.compare.runner import run

__all__ = [
    "DEFAULT_ALGOS",
    "RESULT_COLUMNS",
    "ComparisonFolder",
    "RunSpec",
    "ZooEntry",
    "build_run",
    "known_algos",
    "main",
    "read_entry",
    "run",
]
