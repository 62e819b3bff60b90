"""
Training speed with and without ``MALLOC_TRIM_THRESHOLD_=65536``, the variable Dask's nanny sets in every worker
process it starts (``distributed.nanny.pre-spawn-environ``), in one run on one machine.

Setting the variable, to any value, turns off glibc's dynamic mmap threshold: every allocation above 128 KiB is
then mapped afresh and unmapped when freed, so a model whose batches are images pays page faults on every one.
Each measurement is one comparison run (:func:`~sb3_reinforce.lab.compare.runner.run`, as a worker runs it, with
no cluster) in a fresh process whose environment has the variable or not, alternating; its training seconds
(evaluations excluded) are appended to the CSV.

    python benchmarks/malloc_trim.py --env CarRacing-v3 --vec-env envpool --steps 8000 --repeats 2
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from value_steps_cost import appending_rows

from sb3_reinforce.lab.compare.folder import ComparisonFolder, RunSpec

RESULTS = Path(__file__).parent / "results" / "malloc_trim.csv"

COLUMNS = ["env_id", "vec_env", "malloc_trim_threshold", "repeat", "load_1min", "steps", "train_s", "steps_per_s"]
SETTINGS = ("unset", "65536")

CHILD = """
import sys
from pathlib import Path
from sb3_reinforce.lab.compare.folder import RunSpec
from sb3_reinforce.lab.compare.runner import run
env_id, vec_env, steps, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), Path(sys.argv[4])
run(RunSpec(env_id, "reinforce", 0, steps, steps, 1), out, vec_env=vec_env)
"""


def measure(env_id: str, vec_env: str, steps: int, setting: str) -> tuple[int, float]:
    """Train one run in a fresh process with the variable unset or set to ``setting``: (steps, training seconds)."""
    env = {key: value for key, value in os.environ.items() if key != "MALLOC_TRIM_THRESHOLD_"}
    if setting != "unset":
        env["MALLOC_TRIM_THRESHOLD_"] = setting
    env["OMP_NUM_THREADS"] = "1"
    with tempfile.TemporaryDirectory() as out:
        args = [sys.executable, "-c", CHILD, env_id, vec_env, str(steps), out]
        subprocess.run(args, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        spec = RunSpec(env_id, "reinforce", 0, steps, steps, 1)  # the child's run
        with open(ComparisonFolder(Path(out)).evaluations_path(spec), newline="") as file:
            last = list(csv.DictReader(file))[-1]
    return int(last["steps"]), float(last["wall_time_s"])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", required=True)
    parser.add_argument("--vec-env", default="dummy")
    parser.add_argument("--steps", type=int, default=8000)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rates: dict[str, list[float]] = {setting: [] for setting in SETTINGS}
    with appending_rows(args.out, COLUMNS) as write:
        for repeat in range(args.repeats):
            for setting in SETTINGS:
                load = os.getloadavg()[0]
                steps, seconds = measure(args.env, args.vec_env, args.steps, setting)
                rates[setting].append(steps / seconds)
                write(dict(env_id=args.env, vec_env=args.vec_env, malloc_trim_threshold=setting, repeat=repeat,
                           load_1min=round(load, 2), steps=steps, train_s=round(seconds, 2),
                           steps_per_s=round(steps / seconds, 1)))  # fmt: skip
    mean = {setting: sum(values) / len(values) for setting, values in rates.items()}
    print(f"{args.env}: steps/s unset {mean['unset']:.1f}, 65536 {mean['65536']:.1f} ({mean['unset'] / mean['65536']:.2f}x)")


if __name__ == "__main__":
    main()
