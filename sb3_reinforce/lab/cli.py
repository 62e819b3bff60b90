"""The ``sb3-reinforce`` command: dispatch to ``compare``, ``seed`` or ``report`` (see ``_USAGE``)."""

import sys

from sb3_reinforce.lab.extras import missing_extra

__all__ = ["main"]

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
            from sb3_reinforce.lab.compare.command import main as compare_main

            compare_main(rest)
    elif command == "seed":
        with missing_extra("sb3-reinforce seed", "compare"):
            from sb3_reinforce.lab.seed.reproduction import main as seed_main

            seed_main(rest)
    elif command == "report":
        with missing_extra("sb3-reinforce report", "compare"):
            from sb3_reinforce.lab.report import main as report_main

            report_main(rest)
    else:
        print(f"sb3-reinforce: unknown command {command!r}\n\n{_USAGE}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
