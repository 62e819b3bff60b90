"""
Where the REINFORCE hyperparameter files (``zoo_configs/*.yml``) are, in a source checkout and once installed.

The files live in the repository's ``zoo_configs/`` folder. A wheel ships them inside the package, as
``sb3_reinforce/lab/zoo/configs/`` (``pyproject.toml`` maps that package folder to ``zoo_configs/``).
"""

from pathlib import Path

__all__ = ["CONFIG_NAMES", "config_dirs", "config_path", "shipped_dirs"]

#: The hyperparameter files this package provides, by name (``<name>.yml``).
CONFIG_NAMES = ("reinforce", "reinforce_seed")


def shipped_dirs(package_folder: str, source_folder: str) -> list[Path]:
    """
    Where a folder of files shipped with the package is: inside the installed package, then in a source checkout.

    :param package_folder: Its name inside ``sb3_reinforce/lab/zoo/`` once installed (``pyproject.toml`` maps it)
    :param source_folder: Its name at the repository's root
    :return: Both candidate paths, the installed one first
    """
    here = Path(__file__).resolve().parent
    return [here / package_folder, here.parents[2] / source_folder]


def config_dirs() -> list[Path]:
    """
    The folders searched for the hyperparameter files, first match wins.

    :return: The installed package's ``configs/`` folder, then the source checkout's ``zoo_configs/``.
    """
    return shipped_dirs("configs", "zoo_configs")


def config_path(name: str = "reinforce") -> Path:
    """
    Path of one of the shipped hyperparameter files.

    :param name: One of ``CONFIG_NAMES``: ``"reinforce"`` (the zoo's default for ``--algo reinforce``) or
        ``"reinforce_seed"`` (the seed's setups)
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
