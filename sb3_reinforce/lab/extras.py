"""One-line errors for a missing optional extra and an unregistered environment id; the user's env packages."""

import contextlib
import difflib
import importlib
import os
import sys
from collections.abc import Iterator, Sequence

import gymnasium as gym

__all__ = ["EXTRA_MODULES", "check_env_id", "import_gym_packages", "missing_extra"]

#: The top-level modules each optional extra installs.
EXTRA_MODULES = {
    "compare": ("rl_zoo3", "pandas", "matplotlib", "psutil", "tqdm", "yaml", "optuna", "distributed", "dask"),
    "zoo": ("rl_zoo3", "requests", "pandas", "moviepy", "cv2", "optuna", "yaml"),
    "envpool": ("envpool",),
}


@contextlib.contextmanager
def missing_extra(command: str, extra: str) -> Iterator[None]:
    """
    Turn a ``ModuleNotFoundError`` for a module of ``extra`` into one line naming the extra, and exit status 2.

    :param command: The command, for the message
    :param extra: The optional dependency group (``compare``, ``zoo``, ``envpool``) that provides the modules
    """
    try:
        yield
    except ModuleNotFoundError as error:
        if (error.name or "").split(".")[0] not in EXTRA_MODULES[extra]:
            raise
        print(
            f"{command}: error: the '{extra}' extra is not installed (no module {error.name!r}): "
            f"pip install 'sb3-reinforce[{extra}]'",
            file=sys.stderr,
        )
        sys.exit(2)


def check_env_id(env_id: str) -> None:
    """
    Raise a ``ValueError`` naming the closest registered ids if ``env_id`` is not in Gymnasium's registry.

    :param env_id: The environment id (the packages that register it imported first)
    """
    try:
        gym.spec(env_id)  # also imports the module of a "module:EnvName-v0" id
        return
    except gym.error.Error:
        pass
    close = difflib.get_close_matches(env_id, list(gym.envs.registry), n=3)
    hint = f" Did you mean {' or '.join(close)}?" if close else ""
    raise ValueError(f"Unknown environment {env_id!r}: not in the Gymnasium registry.{hint}")


def import_gym_packages(modules: Sequence[str]) -> None:
    """
    Import the modules that register the user's environments (rl_zoo3's ``--gym-packages``), looking in the current
    folder too, as ``python -m`` does.

    :param modules: Module names (``my_package.envs``)
    :raises ValueError: naming a module that cannot be imported
    """
    if modules and os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())
    for module in modules:
        try:
            importlib.import_module(module)
        except ImportError as error:
            raise ValueError(f"--gym-packages: cannot import {module!r} ({error})") from None
