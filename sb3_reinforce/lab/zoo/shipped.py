"""
What the package ships beside its code, in a checkout and installed (``pyproject.toml`` maps the folders): the
REINFORCE hyperparameter files (``zoo_configs/*.yml``, installed as ``sb3_reinforce/lab/zoo/configs/``) and the trained
agents (``rl-trained-agents/reinforce/<env>_1/``, installed as ``sb3_reinforce/lab/zoo/trained_agents/``), and how
``-f rl-trained-agents`` finds an agent.
"""

from pathlib import Path

__all__ = [
    "CONFIG_NAMES",
    "TRAINED_AGENTS",
    "agents_folder",
    "config_path",
    "shipped_envs",
    "trained_agents_dirs",
]

#: The hyperparameter files this package provides, by name (``<name>.yml``).
CONFIG_NAMES = ("reinforce", "reinforce_seed")


#: This module's folder: the shipped folders are beside it once installed, at the checkout's root (``parents[2]``) else.
_HERE = Path(__file__).resolve().parent


def config_path(name: str = "reinforce") -> Path:
    """
    Path of one of the shipped hyperparameter files.

    :param name: ``"reinforce"`` (the zoo's default for ``--algo reinforce``) or ``"reinforce_seed"`` (the seed's)
    :return: The path of ``<name>.yml``
    """
    if name not in CONFIG_NAMES:
        raise ValueError(f"`name` must be one of {CONFIG_NAMES}, got {name!r}")
    folders = [_HERE / "configs", _HERE.parents[2] / "zoo_configs"]  # installed, then the checkout's
    for folder in folders:
        candidate = folder / f"{name}.yml"
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(folder) for folder in folders)
    raise FileNotFoundError(f"{name}.yml not found (searched {searched}): the sb3-reinforce installation is incomplete")


#: The folder name rl_zoo3's commands default ``-f`` to, and this repository's folder of trained agents.
TRAINED_AGENTS = "rl-trained-agents"


def trained_agents_dirs() -> list[Path]:
    """
    The folders searched for the shipped agents, first match wins.

    :return: The installed ``trained_agents/`` folder, then the checkout's ``rl-trained-agents/``
    """
    return [_HERE / "trained_agents", _HERE.parents[2] / TRAINED_AGENTS]


def _has_agent(folder: Path, algo: str, env_id: str) -> bool:
    """Whether ``folder`` holds a run of ``algo`` on ``env_id`` in the zoo's layout (``<algo>/<env>_<N>/``)."""
    return any(run.is_dir() for run in (folder / algo).glob(f"{env_id}_*"))


def shipped_envs(algo: str = "reinforce") -> list[str]:
    """
    The environments with a shipped agent.

    :param algo: The zoo's name of the algorithm
    :return: Their ids, sorted
    """
    runs = [run for folder in trained_agents_dirs() for run in (folder / algo).glob("*_*") if run.is_dir()]
    return sorted({run.name.rsplit("_", 1)[0] for run in runs})


def agents_folder(folder: str, algo: str, env_id: str) -> str | None:
    """
    The folder the zoo should read for ``-f folder``: the current directory's agent first, else the shipped one.

    :param folder: The ``-f``/``--folder`` argument
    :param algo: The ``--algo`` argument
    :param env_id: The ``--env`` argument
    :return: ``folder`` if not ``rl-trained-agents`` or it holds the agent, else the shipped one holding it, or None
    """
    if folder.rstrip("/") != TRAINED_AGENTS or _has_agent(Path(folder), algo, env_id):
        return folder
    for shipped in trained_agents_dirs():
        if _has_agent(shipped, algo, env_id):
            return str(shipped)
    return None
