"""
The README's main job (``sb3-reinforce compare --env CartPole-v1 --seeds 3``) on the local Dask cluster of this
checkout against the hand-made spawn pool it replaced (a checkout of an older commit, e.g. f454613, given with
``--old``), on the same machine, one after the other: wall-clock time of the command, peak memory of its processes
(the sum of the resident set sizes of the command and every process below it, sampled every 0.2 s), and the start-up
time of the local cluster alone (``LocalCluster`` + ``Client`` on 127.0.0.1 with the command's default worker
processes, until they are all connected). The load average (``/proc/loadavg``) is recorded before and after each
measurement: compare numbers only from a machine that is otherwise idle.

    git worktree add /tmp/sb3r-pool f454613
    python benchmarks/compare_engine.py --old /tmp/sb3r-pool --repeats 1 --out benchmarks/results/compare_engine.csv
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

REPO = Path(__file__).resolve().parents[1]
#: The README's main job (its --out and --no-progress added), after the compare module of the checkout
MAIN_JOB = ["--env", "CartPole-v1", "--seeds", "3", "--no-progress"]
COLUMNS = ["engine", "repeat", "wall_s", "peak_rss_mb", "load_before", "load_after", "returncode"]


def load_average() -> str:
    """The 1, 5 and 15-minute load averages, as ``uptime`` shows them."""
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def tree_rss_mb(process: psutil.Process) -> float:
    """Resident set size (MiB) of ``process`` and of every process below it."""
    total = 0
    for member in [process, *process.children(recursive=True)]:
        try:
            total += member.memory_info().rss
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            pass
    return total / 2**20


def run_main_job(checkout: Path, out: Path) -> tuple[float, float, int]:
    """
    The main job with ``checkout``'s package first on the path.

    :return: wall-clock seconds, peak memory (MiB) of its process tree, exit status
    """
    env = dict(os.environ, PYTHONPATH=str(checkout))
    start = time.perf_counter()
    # the compare package moved under sb3_reinforce/lab/ after the pool was replaced
    module = "sb3_reinforce.lab.compare" if (checkout / "sb3_reinforce" / "lab").is_dir() else "sb3_reinforce.compare"
    command = subprocess.Popen([sys.executable, "-m", module, *MAIN_JOB, "--out", str(out)], env=env, cwd=out.parent)
    parent = psutil.Process(command.pid)
    peak = 0.0
    while command.poll() is None:
        try:
            peak = max(peak, tree_rss_mb(parent))
        except psutil.NoSuchProcess:
            break
        time.sleep(0.2)
    returncode = command.wait()
    return time.perf_counter() - start, peak, returncode


def cluster_start_up_s() -> float:
    """Seconds to start the command's default local cluster and connect to it (every worker connected)."""
    code = """
import os, time
start = time.perf_counter()
from sb3_reinforce.lab.cluster import open_client
workers = os.cpu_count() or 1
with open_client(None, workers, 1) as client:
    client.wait_for_workers(workers)
    print(time.perf_counter() - start)
"""
    done = subprocess.run(
        [sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(REPO)), capture_output=True, text=True
    )
    return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--old", type=Path, required=True, help="a checkout of the commit with the spawn pool")
    parser.add_argument("--repeats", type=int, default=1, help="runs of each engine, interleaved (default: %(default)s)")
    parser.add_argument("--out", type=Path, required=True, help="CSV of the measurements")
    args = parser.parse_args()
    rows = []
    for repeat in range(args.repeats):
        load = load_average()
        start_up = cluster_start_up_s()
        rows.append(dict(engine="dask LocalCluster start-up", repeat=repeat, wall_s=round(start_up, 2)))
        rows[-1].update(peak_rss_mb="", load_before=load, load_after=load_average(), returncode=0)
        for engine, checkout in (("dask", REPO), ("pool", args.old)):
            with tempfile.TemporaryDirectory(prefix=f"compare-{engine}-") as folder:
                load = load_average()
                wall, peak, returncode = run_main_job(checkout, Path(folder) / "out")
                rows.append(
                    dict(engine=engine, repeat=repeat, wall_s=round(wall, 1), peak_rss_mb=round(peak, 1))
                    | dict(load_before=load, load_after=load_average(), returncode=returncode)
                )
            print(rows[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    print(f"Saved {args.out}")


if __name__ == "__main__":
    main()
