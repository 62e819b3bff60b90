"""
Wall time of training the zoo entries with each way of stepping their training environments (``--vec-env``:
``dummy``, ``subproc``, ``envpool``), in one run on one machine.

Each measurement builds a fresh model from the algorithm's zoo entry as ``sb3-reinforce compare`` does (same
wrappers, number of envs, normalization; :func:`~sb3_reinforce.lab.compare.experiment.build_run`) and times
``model.learn(--steps)``: wall-clock seconds, and those spent in the training VecEnv's ``step`` (the environments
and their wrappers; with ``subproc``, the wait for the environment processes), whose share of the wall time is the
``env_share`` column. The ways of stepping run interleaved (dummy, subproc, envpool, dummy, ...) so that a slow
phase of a shared machine hits all of them; the machine's load average when each measurement started is recorded
beside it. Every measurement is appended to the CSV.

    nice -n 5 python benchmarks/vec_env_speed.py --env LunarLander-v3 --steps 20000
    nice -n 5 python benchmarks/vec_env_speed.py --env CarRacing-v3 --steps 5000
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
COLUMNS += ["steps_per_s"]


def measure(env_id: str, algo: str, vec_env: str, steps: int, seed: int) -> dict[str, Any]:
    """Train a fresh model of ``algo``'s zoo entry for ``steps`` steps, its training envs stepped as ``vec_env``."""
    th.set_num_threads(1)
    with tempfile.TemporaryDirectory() as log_folder:
        built = build_run(algo, env_id, seed, steps, Path(log_folder), vec_env=vec_env)
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
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    algos, vec_envs = args.algos.split(","), args.vec_envs.split(",")
    rows = []
    with appending_rows(args.out, COLUMNS) as write:
        for algo in algos:
            for repeat in range(args.repeats):
                for vec_env in vec_envs:
                    row = dict(env_id=args.env, algo=algo, vec_env=vec_env, repeat=repeat)
                    row.update(measure(args.env, algo, vec_env, args.steps, args.seed))
                    write(row)
                    rows.append(row)
    for algo in algos:
        rates = {
            v: statistics.median(r["steps_per_s"] for r in rows if (r["algo"], r["vec_env"]) == (algo, v)) for v in vec_envs
        }
        print(
            f"{algo}: steps/s " + ", ".join(f"{v} {rate:.1f} ({rate / rates[vec_envs[0]]:.2f}x)" for v, rate in rates.items())
        )


if __name__ == "__main__":
    main()
