"""
The ``sb3-reinforce`` command:

- ``sb3-reinforce compare ...``: REINFORCE vs PPO vs A2C (:mod:`sb3_reinforce.compare`)
- ``sb3-reinforce seed ...``: the seed's agent for N episodes (:mod:`sb3_reinforce.seed_reproduction`)
- ``sb3-reinforce report DIR [DIR ...]``: rebuild a result folder's tables and plot, print its markdown table
"""

import contextlib
import sys
from collections.abc import Iterator

__all__ = ["main", "missing_extra"]

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


_USAGE = """usage: sb3-reinforce {compare,seed,report} ...

  compare   train REINFORCE, PPO and A2C on one env, same seeds and evaluation (--help for options)
  seed      train the seed's agent for a number of episodes (--help for options)
  report    rebuild the tables and plots of result folders and print their markdown tables
"""


def main(argv: list[str] | None = None) -> None:
    """Dispatch to a sub-command."""
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help"):
        print(_USAGE)
        sys.exit(0 if argv else 2)
    command, rest = argv[0], argv[1:]
    if command == "compare":
        with missing_extra("sb3-reinforce compare", "compare"), missing_extra("sb3-reinforce compare", "envpool"):
            from sb3_reinforce.compare.cli import main as compare_main

            compare_main(rest)
    elif command == "seed":
        with missing_extra("sb3-reinforce seed", "compare"):
            from sb3_reinforce.seed_reproduction import main as seed_main

            seed_main(rest)
    elif command == "report":
        with missing_extra("sb3-reinforce report", "compare"):
            from sb3_reinforce.compare.render import main as report_main

            report_main(rest)
    else:
        print(f"sb3-reinforce: unknown command {command!r}\n\n{_USAGE}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
