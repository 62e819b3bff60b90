"""
REINFORCE in rl-baselines3-zoo (``rl_zoo3``, the ``zoo`` extra): ``python -m sb3_reinforce.lab.zoo`` or
``sb3-reinforce-zoo`` runs rl_zoo3's commands (``train``, ``enjoy``, ``benchmark``, ``record-video``,
``record_training``, the plots, the Hub's ``push_to_hub`` and ``load_from_hub``) with ``--algo reinforce``
registered. Importing this package registers nothing; :func:`register` does.
"""

from sb3_reinforce.lab.zoo.cli import COMMANDS, main, register
from sb3_reinforce.lab.zoo.shipped import config_path

__all__ = ["COMMANDS", "config_path", "main", "register"]
