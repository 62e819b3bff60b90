"""The benchmark scripts run on a tiny budget and write their CSV (no timing is asserted: speed lives in the scripts)."""

import csv
import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import torch as th

BENCHMARKS = Path(__file__).parent.parent / "benchmarks"


def load(name: str) -> ModuleType:
    if str(BENCHMARKS) not in sys.path:  # as when run as a script: the benchmarks import each other
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(f"benchmarks_{name}", BENCHMARKS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def read_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


def test_throughput_tiny_budget(tmp_path: Path) -> None:
    throughput = load("throughput")
    out = tmp_path / "throughput.csv"
    variants = ["raw", "limit", "limit_fast", "reinforce", "a2c"]
    threads = th.get_num_threads()
    try:
        args = ["--envs", "CartPole-v1", "--n-envs", "2", "--steps", "200", "--repeats", "1", "--variants", *variants]
        throughput.main([*args, "--out", str(out)])
    finally:
        th.set_num_threads(threads)
    rows = read_rows(out)
    assert [(row["env_id"], row["n_envs"]) for row in rows] == [("CartPole-v1", "2")]
    for row in rows:
        for variant in variants:
            assert float(row[f"{variant}_steps_per_s"]) > 0
        assert float(row["reinforce_over_raw"]) > 0 and float(row["reinforce_over_a2c"]) > 0
        assert math.isnan(float(row["reinforce_over_ppo"]))  # PPO was not measured


def test_rollout_ceiling_tiny_budget(tmp_path: Path) -> None:
    ceiling = load("rollout_ceiling")
    out = tmp_path / "ceiling.csv"
    threads = th.get_num_threads()
    try:
        ceiling.main(["--env", "CartPole-v1", "--n-envs", "2", "--steps", "300", "--repeats", "1", "--out", str(out)])
    finally:
        th.set_num_threads(threads)
    (row,) = read_rows(out)
    parts = [float(row[f"{part} ms"]) for part in ceiling.PARTS]
    assert all(part > 0 for part in parts)  # every counter was hit: learn() still calls each wrapped part
    assert int(row["updates"]) >= 1 and int(row["vec_env steps"]) >= 150
    assert sum(parts) <= float(row["learn ms"]) + 1e-6
    assert 0 < float(row["R/raw"]) <= float(row["bound: no train"]) <= float(row["bound: env only"])


def test_memory_tiny_budget(tmp_path: Path) -> None:
    memory = load("memory")
    out = tmp_path / "memory.csv"
    threads = th.get_num_threads()
    try:  # in this process: a fresh one would spend seconds importing torch
        memory.main(["--runs", "reinforce:300", "--env", "CartPole-v1", "--in-process", "--out", str(out)])
    finally:
        th.set_num_threads(threads)
    (row,) = read_rows(out)
    assert row["algo"] == "reinforce" and int(row["steps"]) >= 300
    assert float(row["peak_rss_mib"]) >= float(row["rss_before_learn_mib"]) > 0


def test_memory_env_alone_tiny_budget(tmp_path: Path) -> None:
    memory = load("memory")
    out = tmp_path / "memory.csv"
    threads = th.get_num_threads()
    try:
        memory.main(["--runs", "random:300", "--env", "CartPole-v1", "--n-envs", "2", "--in-process", "--out", str(out)])
    finally:
        th.set_num_threads(threads)
    (row,) = read_rows(out)
    assert (row["algo"], row["env_id"], row["n_envs"], row["steps"]) == ("random", "CartPole-v1", "2", "300")
    assert float(row["peak_rss_mib"]) >= float(row["rss_before_learn_mib"]) > 0
