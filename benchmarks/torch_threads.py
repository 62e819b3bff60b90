"""
Torch's threads in REINFORCE's ``learn`` (issue 62): a run with torch's default thread count against the same run on
one thread, each in a fresh process (torch fixes its thread pool at the first parallel operation), timed on the
wall clock with the machine's 1-minute load average at its start. Repeats alternate the two settings, so that a
change of load touches both alike. ``--tag`` records the load asked for: ``idle`` (pause every background run first)
or ``loaded`` (beside them).

    python benchmarks/torch_threads.py --env CartPole-v1 --steps 50000 --repeats 3 --tag idle

Rows append to ``results/torch_threads.csv``: tag, env, policy, threads asked (``default`` or 1), torch's thread count
in the run, steps, training seconds, steps/s, load average, CPU model and core count.
"""

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from sb3_reinforce.lab.provenance import system_info

RESULTS = Path(__file__).parent / "results" / "torch_threads.csv"
COLUMNS = ["tag", "env_id", "kwargs", "threads", "torch_threads", "steps", "seconds", "steps_per_s", "load_1min"]
COLUMNS += ["cpu", "cores"]


def one_run(env_id: str, steps: int, threads: int | None, kwargs: dict[str, Any], seed: int) -> dict[str, Any]:
    """In this process: train a fresh REINFORCE for ``steps`` with ``threads`` torch threads (None: torch's default)."""
    import torch as th

    from sb3_reinforce import REINFORCE

    if threads is not None:
        th.set_num_threads(threads)
    model = REINFORCE("MlpPolicy", env_id, seed=seed, device="cpu", **kwargs)
    load = os.getloadavg()[0]
    start = time.perf_counter()
    model.learn(steps)
    seconds = time.perf_counter() - start
    return dict(torch_threads=th.get_num_threads(), steps=model.num_timesteps, seconds=seconds, load_1min=load)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="CartPole-v1")
    parser.add_argument("--steps", type=int, default=50_000)
    parser.add_argument("--kwargs", default="{}", help="REINFORCE's arguments as JSON (default: its defaults)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--tag", required=True, help="idle or loaded, recorded as is")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    kwargs = json.loads(args.kwargs)
    if args.child is not None:  # one measurement, in its own process
        threads = None if args.child == "default" else int(args.child)
        print(json.dumps(one_run(args.env, args.steps, threads, kwargs, args.seed)))
        return
    new_file = not args.out.exists()
    with args.out.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()
        for _ in range(args.repeats):
            for threads in ("default", "1"):
                command = [sys.executable, __file__, "--env", args.env, "--steps", str(args.steps), "--seed", str(args.seed)]
                command += ["--kwargs", args.kwargs, "--tag", args.tag, "--child", threads]
                child = subprocess.run(command, capture_output=True, text=True, check=True)
                result = json.loads(child.stdout.splitlines()[-1])
                row = {"tag": args.tag, "env_id": args.env, "kwargs": args.kwargs, "threads": threads, **result}
                row.update(steps_per_s=round(row["steps"] / row["seconds"], 1), seconds=round(row["seconds"], 2))
                row.update(load_1min=round(row["load_1min"], 2), cpu=system_info()["CPU"], cores=os.cpu_count())
                writer.writerow(row)
                file.flush()
                print(", ".join(f"{key}={row[key]}" for key in COLUMNS))


if __name__ == "__main__":
    main()
