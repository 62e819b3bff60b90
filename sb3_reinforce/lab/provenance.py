"""
What decides a run's numbers besides its settings, recorded in each run's summary: the code (:func:`code_version`)
and the machine and libraries (:func:`system_info`). A run is reproducible bit for bit only where both are the same:
the same versions of torch, numpy, gymnasium, stable-baselines3 and rl_zoo3, on the same CPU type (torch picks its
kernels by the CPU's instruction set, and their floating-point sums differ in the last bits).
"""

import importlib.metadata
import platform
import subprocess
from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3.common.utils import get_system_info

from sb3_reinforce.version import __version__

__all__ = ["NUMERIC_KEYS", "code_version", "differences", "system_info"]

#: The entries of :func:`system_info` that decide a run's numbers (the OS string, GPU flag and cloudpickle left out).
NUMERIC_KEYS = (
    "Python",
    "Stable-Baselines3",
    "PyTorch",
    "Numpy",
    "Gymnasium",
    "rl_zoo3",
    "sb3_reinforce",
    "CPU",
    "PyTorch CPU capability",
    "PyTorch threads",
)


def code_version() -> dict[str, Any]:
    """
    The package version and, in a git checkout, the commit and whether tracked files differ (taken in the run's worker).

    :return: ``{"sb3_reinforce": version, "git_commit": hash or None, "git_dirty": bool or None}``
    """
    package_dir = Path(__file__).resolve().parent

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", *args], cwd=package_dir, capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    status = None if commit is None else git("status", "--porcelain", "--untracked-files=no")
    return {"sb3_reinforce": __version__, "git_commit": commit, "git_dirty": None if status is None else status != ""}


def _cpu_model() -> str:
    """The CPU's model name (Linux's ``/proc/cpuinfo``; elsewhere what :mod:`platform` knows)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def system_info() -> dict[str, str]:
    """
    SB3's ``get_system_info`` (OS, Python, Stable-Baselines3, PyTorch, GPU, Numpy, Cloudpickle, Gymnasium), plus
    rl_zoo3's and this package's versions, the CPU model, the instruction set torch's CPU kernels use and torch's
    threads in this process.
    """
    info, _ = get_system_info(print_info=False)
    try:
        zoo_version = importlib.metadata.version("rl_zoo3")
    except importlib.metadata.PackageNotFoundError:
        zoo_version = "not installed"
    return {
        **{key: str(value) for key, value in info.items()},  # torch's version is a TorchVersion, compared as one
        "rl_zoo3": zoo_version,
        "sb3_reinforce": __version__,
        "CPU": _cpu_model(),
        "PyTorch CPU capability": th.backends.cpu.get_cpu_capability(),
        "PyTorch threads": str(th.get_num_threads()),
    }


def differences(systems: list[dict[str, str]]) -> dict[str, list[str]]:
    """
    The :data:`NUMERIC_KEYS` on which ``systems`` differ, with the values seen ("not recorded": a system without
    that key).

    :param systems: The runs' :func:`system_info`
    :return: ``{key: sorted distinct values}`` for each key with more than one value
    """
    seen: dict[str, set[str]] = {key: {system.get(key, "not recorded") for system in systems} for key in NUMERIC_KEYS}
    return {key: sorted(values) for key, values in seen.items() if len(values) > 1}
