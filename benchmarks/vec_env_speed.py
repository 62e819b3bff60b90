"""
Wall time of training the zoo entries with each way of stepping their training environments (``--vec-env``:
``dummy``, ``subproc``, ``envpool``), in one run on one machine.

Each measurement builds a fresh model from the algorithm's zoo entry as ``sb3-reinforce compare`` does (same
wrappers, number of envs, normalization; :func:`~sb3_reinforce.lab.compare.experiment.build_run`) and times
``model.learn(--steps)``: wall-clock seconds, and those spent in the training VecEnv's ``step`` (the environments
and their wrappers; with ``subproc``, the wait for the environment processes), whose share of the wall time is the
``env_share`` column. The ways of stepping run interleaved (dummy, subproc, envpool, dummy, ...) so that a slow
phase of a shared machine hits all of them; the machine's load average when each measurement started is recorded
beside it. Every measurement is appended to the CSV. ``--envpool-threads`` measures EnvPool with each number of
worker threads given (``envpool_threads``: 0 is EnvPool's default, one per core; compare's runs use 1).

    nice -n 5 python benchmarks/vec_env_speed.py --env LunarLander-v3 --steps 20000
    nice -n 5 python benchmarks/vec_env_speed.py --env CarRacing-v3 --steps 5000

Two runs on two cores, as the CarRacing study trains, EnvPool's default threads against one (both commands at once):

    python benchmarks/vec_env_speed.py --env CarRacing-v3 --algos reinforce --vec-envs envpool \
        --envpool-threads 0,1 --steps 4000 --repeats 3
"""

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import torch as th
from value_steps_cost import appending_rows, timed

from sb3_reinforce.lab.compare.experiment import VEC_ENV_TYPES, build_run

RESULTS = Path(__file__).parent / "results" / "vec_env_speed.csv"
COLUMNS = ["env_id", "algo", "vec_env", "n_envs", "repeat", "load_1min", "steps", "wall_s", "env_step_s", "env_share"]
COLUMNS += ["steps_per_s", "envpool_threads"]


def measure(env_id: str, algo: str, vec_env: str, steps: int, seed: int, envpool_threads: int = 0) -> dict[str, Any]:
    """Train a fresh model of ``algo``'s zoo entry for ``steps`` steps, its training envs stepped as ``vec_env``."""
    th.set_num_threads(1)
    with tempfile.TemporaryDirectory() as log_folder:
        built = build_run(algo, env_id, seed, steps, Path(log_folder), vec_env=vec_env, envpool_threads=envpool_threads)
        env_seconds = [0.0]
        built.train_env.step = timed(built.train_env.step, env_seconds)  # type: ignore[method-assign]
        load = os.getloadavg()[0]
        wall = time.perf_counter()
        built.model.learn(steps)
        wall = time.perf_counter() - wall
        built.train_env.close()
        built.eval_env.close()
    n = built.model.num_timesteps
    return dict(n_envs=built.entry.n_envs, load_1min=round(load, 2), steps=n, wall_s=round(wall, 2),
                env_step_s=round(env_seconds[0], 2), env_share=round(env_seconds[0] / wall, 3),
                steps_per_s=round(n / wall, 2))  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", required=True)
    parser.add_argument("--algos", default="reinforce,ppo", help="comma-separated zoo algorithms (default: %(default)s)")
    parser.add_argument("--vec-envs", default=",".join(VEC_ENV_TYPES), help="comma-separated (default: %(default)s)")
    parser.add_argument("--steps", type=int, default=20_000, help="steps per measurement (learn may run past: whole batches)")
    parser.add_argument("--envpool-threads", default="0", help="comma-separated EnvPool worker threads (default: 0)")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    algos, threads = args.algos.split(","), [int(n) for n in args.envpool_threads.split(",")]
    # a way of stepping: (vec_env, EnvPool threads), the threads blank for the others
    ways = [(v, n) for v in args.vec_envs.split(",") for n in (threads if v == "envpool" else [""])]
    names = [v if n == "" or len(threads) == 1 else f"{v} ({n} threads)" for v, n in ways]
    rows = []
    with appending_rows(args.out, COLUMNS) as write:
        for algo in algos:
            for repeat in range(args.repeats):
                for vec_env, n in ways:
                    row = dict(env_id=args.env, algo=algo, vec_env=vec_env, repeat=repeat, envpool_threads=n)
                    row.update(measure(args.env, algo, vec_env, args.steps, args.seed, int(n or 0)))
                    write(row)
                    rows.append(row)
    for algo in algos:
        rates = [
            statistics.median(
                r["steps_per_s"] for r in rows if (r["algo"], r["vec_env"], r["envpool_threads"]) == (algo, *way)
            )
            for way in ways
        ]
        print(
            f"{algo}: steps/s "
            + ", ".join(f"{name} {rate:.1f} ({rate / rates[0]:.2f}x)" for name, rate in zip(names, rates, strict=True))
        )


if __name__ == "__main__":
    main()
