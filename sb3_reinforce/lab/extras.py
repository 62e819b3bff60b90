"""The one-line message for a command whose optional extra (``pip install 'sb3-reinforce[EXTRA]'``) is missing."""

import contextlib
import sys
from collections.abc import Iterator

__all__ = ["EXTRA_MODULES", "missing_extra"]

#: The top-level modules each optional extra installs (pyproject.toml's optional-dependencies).
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
