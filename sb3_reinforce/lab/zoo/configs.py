"""
The REINFORCE hyperparameter files: ``zoo_configs/*.yml`` in a checkout, ``sb3_reinforce/lab/zoo/configs/`` installed.
"""

from pathlib import Path

__all__ = ["CONFIG_NAMES", "config_dirs", "config_path", "shipped_dirs"]

#: The hyperparameter files this package provides, by name (``<name>.yml``).
CONFIG_NAMES = ("reinforce", "reinforce_seed")


def shipped_dirs(package_folder: str, source_folder: str) -> list[Path]:
    """
    The candidate paths of a folder shipped with the package.

    :param package_folder: Its name inside ``sb3_reinforce/lab/zoo/`` once installed
    :param source_folder: Its name at the repository's root
    :return: Both candidate paths, the installed one first
    """
    here = Path(__file__).resolve().parent
    return [here / package_folder, here.parents[2] / source_folder]


def config_dirs() -> list[Path]:
    """
    The folders searched for the hyperparameter files, first match wins.

    :return: The installed ``configs/`` folder, then the checkout's ``zoo_configs/``
    """
    return shipped_dirs("configs", "zoo_configs")


def config_path(name: str = "reinforce") -> Path:
    """
    Path of one of the shipped hyperparameter files.

    :param name: ``"reinforce"`` (the zoo's default for ``--algo reinforce``) or ``"reinforce_seed"`` (the seed's)
    :return: The path of ``<name>.yml``
    """
    if name not in CONFIG_NAMES:
        raise ValueError(f"`name` must be one of {CONFIG_NAMES}, got {name!r}")
    for folder in config_dirs():
        candidate = folder / f"{name}.yml"
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(folder) for folder in config_dirs())
    raise FileNotFoundError(f"{name}.yml not found (searched {searched}): the sb3-reinforce installation is incomplete")
