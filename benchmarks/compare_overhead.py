"""
What ``sb3-reinforce compare`` itself costs: the README's main job (``compare --env CartPole-v1 --seeds 3``: 9 runs,
two at a time on the local Dask cluster) against the same nine runs as plain processes, two at a time (each run a
``python -c`` of :func:`sb3_reinforce.lab.compare.runner.run`, the function compare's workers call, with the same
settings and so the same evaluations), interleaved (compare, plain, compare, plain, ...) so that a slow phase of the
machine hits both. Each measurement's wall-clock time, the peak memory of its process tree and the load average
before and after are appended to the CSV, and the deterministic evaluation columns of the two are checked equal.

    python benchmarks/compare_overhead.py --repeats 3 --out benchmarks/results/compare_overhead.csv
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import psutil
from compare_engine import load_average, tree_rss_mb

REPO = Path(__file__).resolve().parents[1]
MAIN_JOB = ["--env", "CartPole-v1", "--seeds", "3", "--no-progress"]
ALGOS = ("reinforce", "ppo", "a2c")
COLUMNS = ["mode", "repeat", "wall_s", "peak_rss_mb", "load_before", "load_after", "returncode"]
RUN_ONE = (
    "import sys; from pathlib import Path; from sb3_reinforce.lab.compare.folder import RunSpec; "
    "from sb3_reinforce.lab.compare.runner import run; "
    "run(RunSpec('CartPole-v1', sys.argv[1], int(sys.argv[2]), 100000, 5000, 5), Path(sys.argv[3]))"
)


def watched(start: Callable[[], list[subprocess.Popen]]) -> tuple[float, float, int]:
    """Wall-clock seconds, peak memory (MiB) of the process trees and worst exit status of what ``start`` starts."""
    begin = time.perf_counter()
    processes = start()
    peak = 0.0
    while any(p.poll() is None for p in processes):
        peak = max(peak, sum(tree_rss_mb(psutil.Process(p.pid)) for p in processes if p.poll() is None))
        time.sleep(0.2)
    return time.perf_counter() - begin, peak, max(p.returncode for p in processes)


def compare(out: Path) -> tuple[float, float, int]:
    """The main job under compare."""
    command = [sys.executable, "-m", "sb3_reinforce.lab.compare", *MAIN_JOB, "--out", str(out)]
    return watched(lambda: [subprocess.Popen(command)])


def plain(out: Path) -> tuple[float, float, int]:
    """The same nine runs, seed-major as compare orders them, as plain processes two at a time."""
    specs = [(algo, seed) for seed in range(3) for algo in ALGOS]
    begin = time.perf_counter()
    peak = [0.0]

    def one(spec: tuple[str, int]) -> int:
        process = subprocess.Popen([sys.executable, "-c", RUN_ONE, spec[0], str(spec[1]), str(out)])
        while process.poll() is None:
            peak[0] = max(peak[0], tree_rss_mb(psutil.Process(process.pid)))  # one process's own peak
            time.sleep(0.2)
        return process.returncode

    with ThreadPoolExecutor(2) as pool:
        codes = list(pool.map(one, specs))
    return time.perf_counter() - begin, peak[0], max(codes)


def deterministic_columns(out: Path) -> pd.DataFrame:
    """Every run's deterministic evaluations, in one order."""
    frames = [pd.read_csv(path) for path in sorted((out / "per_run").glob("*.csv"))]
    table = pd.concat(frames)[["algo", "seed", "eval_index", "steps", "mean_return", "std_return"]]
    return table.sort_values(["algo", "seed", "eval_index"]).reset_index(drop=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "compare_overhead.csv")
    args = parser.parse_args()
    new_file = not args.out.exists()
    with args.out.open("a", newline="") as file, tempfile.TemporaryDirectory() as scratch:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()
        for repeat in range(args.repeats):
            for mode, measure in (("compare", compare), ("plain", plain)):
                out = Path(scratch) / f"{mode}{repeat}"
                out.mkdir()
                before = load_average()
                wall, peak, code = measure(out)
                row = dict(mode=mode, repeat=repeat, wall_s=round(wall, 1), peak_rss_mb=round(peak, 1))
                row |= dict(load_before=before, load_after=load_average(), returncode=code)
                writer.writerow(row)
                file.flush()
                print(", ".join(f"{key}={value}" for key, value in row.items()), flush=True)
            same = deterministic_columns(Path(scratch) / f"compare{repeat}").equals(
                deterministic_columns(Path(scratch) / f"plain{repeat}")
            )
            print(f"repeat {repeat}: deterministic evaluations of compare and plain equal: {same}", flush=True)
    os.sync()


if __name__ == "__main__":
    main()
