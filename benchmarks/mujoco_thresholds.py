"""Each MuJoCo env's solve threshold, read off the published table (benchmarks/published/reinforce_mujoco.csv).

The threshold is the higher published number at 3M steps (Tianshou's REINFORCE, Spinning Up's VPG), so a run's
"steps to reach" reads when it first matched both; ``--source NAME`` takes one source's number instead (e.g.
``--source "Tianshou REINFORCE"``). Prints ``ENV THRESHOLD`` lines in the table's order, for the envs named on the
command line (all when none is): ``mujoco_table.sh`` and the studies' ``run.sh`` read them.
An env the table does not have is an error naming the ones it has.
"""

import sys
from pathlib import Path

import pandas as pd

PUBLISHED = Path(__file__).parent / "published" / "reinforce_mujoco.csv"


def thresholds(published: Path = PUBLISHED, source: str | None = None) -> pd.Series:
    """The higher published mean at 3M steps of each env (or ``source``'s), in the table's order."""
    table = pd.read_csv(published)
    table = table[table["budget"] == 3_000_000]
    if source is not None:
        if source not in set(table["source"]):
            sys.exit(f"no source {source!r}: the table has {', '.join(table['source'].unique())}")
        table = table[table["source"] == source]
    return table.groupby("env_id", sort=False)["mean"].max()


def main(env_ids: list[str]) -> None:
    source = None
    if env_ids[:1] == ["--source"]:
        source, env_ids = env_ids[1], env_ids[2:]
    known = thresholds(source=source)
    unknown = [env_id for env_id in env_ids if env_id not in known.index]
    if unknown:
        sys.exit(f"no published number for {', '.join(unknown)}: the table has {', '.join(known.index)}")
    for env_id, threshold in known.items():
        if not env_ids or env_id in env_ids:
            print(env_id, threshold)


if __name__ == "__main__":
    main(sys.argv[1:])
