"""
What the value baseline's own fitting steps (``n_value_steps``) cost, with the critic's features computed once per
batch (the cached path of ``REINFORCE._fit_value``, the default with a shared
features extractor) against every step running the whole network through ``predict_values`` (the path before it, and
still the one for a critic with its own extractor), in one run.

Each measurement builds a fresh model from a zoo config as ``sb3-reinforce compare`` does (same wrappers, same
number of envs) and times ``model.learn(--steps)``: wall-clock and CPU seconds (``time.process_time``, which a
busy machine disturbs less), the seconds spent in the value steps and those spent in the training VecEnv's
``step`` (the environment and its wrappers). The two paths run interleaved (cached,
full, cached, full, ...) so that a slow phase of a shared machine hits both; the medians and their ratio are
printed and every measurement is appended to the CSV.

    python benchmarks/value_steps_cost.py --env CarRacing-v3 --config benchmarks/configs/carracing_pilot/b_value20.yml \\
        --steps 4000 --repeats 2
"""

import argparse
import contextlib
import csv
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import torch as th

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.compare.experiment import build_run

RESULTS = Path(__file__).parent / "results" / "value_steps_cost.csv"
COLUMNS = ["env_id", "config", "path", "repeat", "steps", "wall_s", "cpu_s", "value_steps_s", "env_step_s", "steps_per_s"]
COLUMNS += ["cpu_steps_per_s"]


def timed(function: Callable[..., Any], seconds: list[float]) -> Callable[..., Any]:
    """``function``, adding the wall-clock seconds of each call to ``seconds[0]``."""

    def wrapper(*args: Any) -> Any:
        start = time.perf_counter()
        try:
            return function(*args)
        finally:
            seconds[0] += time.perf_counter() - start

    return wrapper


@contextlib.contextmanager
def appending_rows(out: Path, columns: list[str]) -> Iterator[Callable[[dict[str, Any]], None]]:
    """A function that appends a row to the CSV ``out`` (its header first if the file is new), flushed and printed."""
    new_file = not out.exists()
    with out.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=columns)
        if new_file:
            writer.writeheader()

        def write(row: dict[str, Any]) -> None:
            writer.writerow(row)
            file.flush()
            print(row, flush=True)

        yield write


def measure(env_id: str, config: Path, path: str, steps: int, seed: int) -> dict[str, Any]:
    """Train a fresh model for ``steps`` steps with the ``cached`` or the ``full`` value-step path."""
    th.set_num_threads(1)
    with tempfile.TemporaryDirectory() as log_folder:
        built = build_run("reinforce", env_id, seed, steps, Path(log_folder), config)
        model = built.model
        assert isinstance(model, REINFORCE) and model.n_value_steps > 0, "the config must fit the value by steps of its own"
        value_seconds, env_seconds = [0.0], [0.0]
        model._fit_value = timed(model._fit_value, value_seconds)  # type: ignore[method-assign]
        built.train_env.step = timed(built.train_env.step, env_seconds)  # type: ignore[method-assign]
        if path == "full":  # every value step through predict_values: the features extractor forward and backward
            base = type(model.policy)  # a policy class with a predict_values of its own makes _fit_value call it
            own_predict_values = {"predict_values": lambda self, obs: base.predict_values(self, obs)}
            model.policy.__class__ = type(f"Full{base.__name__}", (base,), own_predict_values)
        wall, cpu = time.perf_counter(), time.process_time()
        model.learn(steps)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        built.train_env.close()
        built.eval_env.close()
    n = model.num_timesteps
    return dict(steps=n, wall_s=round(wall, 2), cpu_s=round(cpu, 2), value_steps_s=round(value_seconds[0], 2),
                env_step_s=round(env_seconds[0], 2), steps_per_s=round(n / wall, 2),
                cpu_steps_per_s=round(n / cpu, 2))  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", required=True)
    parser.add_argument("--config", type=Path, required=True, help="zoo yml: the env's REINFORCE entry, n_value_steps > 0")
    parser.add_argument("--steps", type=int, default=4000, help="steps per measurement (whole batches: learn may run past)")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows = []
    with appending_rows(args.out, COLUMNS) as write:
        for repeat in range(args.repeats):
            for path in ("cached", "full"):
                row = dict(env_id=args.env, config=str(args.config), path=path, repeat=repeat)
                row.update(measure(args.env, args.config, path, args.steps, args.seed))
                write(row)
                rows.append(row)
    for key in ("steps_per_s", "cpu_steps_per_s", "value_steps_s", "env_step_s", "wall_s"):
        cached, full = (statistics.median(r[key] for r in rows if r["path"] == p) for p in ("cached", "full"))
        print(f"{key}: cached {cached:.2f}, full {full:.2f}, cached / full {cached / full:.2f}")


if __name__ == "__main__":
    main()
