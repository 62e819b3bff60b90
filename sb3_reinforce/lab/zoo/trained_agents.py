"""
The shipped REINFORCE agents (``rl-trained-agents/reinforce/<env>_1/`` in a checkout,
``sb3_reinforce/lab/zoo/trained_agents/`` installed) and how ``-f rl-trained-agents`` finds them.
"""

from pathlib import Path

from sb3_reinforce.lab.zoo.configs import shipped_dirs

__all__ = ["TRAINED_AGENTS", "agents_folder", "shipped_envs", "trained_agents_dirs"]

#: The folder name rl_zoo3's commands default ``-f`` to, and this repository's folder of trained agents.
TRAINED_AGENTS = "rl-trained-agents"


def trained_agents_dirs() -> list[Path]:
    """
    The folders searched for the shipped agents, first match wins.

    :return: The installed ``trained_agents/`` folder, then the checkout's ``rl-trained-agents/``
    """
    return shipped_dirs("trained_agents", TRAINED_AGENTS)


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
