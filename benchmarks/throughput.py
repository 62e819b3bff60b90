"""
Throughput of REINFORCE against the speed limits of its own rollout loop, and against SB3's PPO and A2C.

For every environment and number of environments (one ``DummyVecEnv`` per measurement, built the same way),
it measures environment steps per second of:

- ``raw``: the VecEnv alone, stepped with pre-drawn uniformly random actions (no policy at all);
- ``limit``: the collection limit: the VecEnv stepped with one policy forward pass per step through SB3's
  ``policy.get_distribution(obs).get_actions()``, no learning (what any SB3 on-policy learner with
  that policy pays at least);
- ``limit_fast``: the same loop, with REINFORCE's fast sampler (``ReinforcePolicy.fast_sampler()``)
  instead of SB3's distribution objects, when the policy has one;
- ``reinforce``, ``reinforce_value``: ``REINFORCE.learn()`` without and with ``baseline="value"``;
- ``reinforce_sb3_sampling``: ``REINFORCE.learn()`` without baseline, with ``policy_kwargs=dict(fast_rollout=False)``:
  the rollout samples through SB3's distribution objects, as before the fast path existed;
- ``ppo``, ``a2c``: SB3's ``PPO.learn()`` and ``A2C.learn()`` with their default settings.

All use the default ``MlpPolicy`` actor (64-64 tanh) and torch pinned to the same number of threads. The
variants run interleaved (one of each, then the next repeat) and the median over the repeats is reported,
so that a slow phase of a shared machine hits all of them alike. Only ``learn()`` (or the stepping loop)
is timed: building the model and the VecEnv is not.

Usage::

    python benchmarks/throughput.py                      # full budget: 4096 steps per measurement, 3 repeats
    python benchmarks/throughput.py --steps 2000 --repeats 1 --envs CartPole-v1 --n-envs 1   # seconds
"""

import argparse
import csv
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch as th
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import obs_as_tensor
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv

from sb3_reinforce import REINFORCE

VARIANTS = ("raw", "limit", "limit_fast", "reinforce", "reinforce_value", "reinforce_sb3_sampling", "ppo", "a2c")
RESULTS = Path(__file__).parent / "results" / "throughput.csv"


def make_env(env_id: str, n_envs: int, seed: int) -> VecEnv:
    """The VecEnv every variant uses: ``make_vec_env`` (Monitor-wrapped envs) in a ``DummyVecEnv``."""
    return make_vec_env(env_id, n_envs=n_envs, seed=seed, vec_env_cls=DummyVecEnv)


def time_raw(env: VecEnv, steps: int, seed: int, clock: Callable[[], float] = time.perf_counter) -> tuple[int, float]:
    """Step the VecEnv with random actions drawn in advance (the environment's own rate), timed by ``clock``."""
    n_iters = max(1, steps // env.num_envs)
    env.action_space.seed(seed)
    actions = [np.stack([env.action_space.sample() for _ in range(env.num_envs)]) for _ in range(min(n_iters, 1024))]
    env.reset()
    start = clock()
    for i in range(n_iters):
        env.step(actions[i % len(actions)])
    return n_iters * env.num_envs, clock() - start


def time_policy_loop(env: VecEnv, model: REINFORCE, steps: int, fast: bool) -> tuple[int, float]:
    """
    Step the VecEnv with one policy forward pass per step and no learning: SB3's distribution path
    (``fast=False``), or the policy's fast sampler. Box actions are clipped as every on-policy learner does.
    """
    policy = model.policy
    policy.set_training_mode(False)
    n_iters = max(1, steps // env.num_envs)
    low, high = getattr(env.action_space, "low", None), getattr(env.action_space, "high", None)
    shape = (-1, *env.action_space.shape)  # type: ignore[misc]
    sampler = policy.fast_sampler() if fast else None
    obs = env.reset()
    start = time.perf_counter()
    for _ in range(n_iters):
        if sampler is not None:
            actions = sampler(obs)
        else:
            with th.no_grad():
                actions = policy.get_distribution(obs_as_tensor(obs, policy.device)).get_actions().cpu().numpy()
            actions = actions.reshape(shape)
        if low is not None:
            actions = np.clip(actions, low, high)
        obs, _, _, _ = env.step(actions)
    return n_iters * env.num_envs, time.perf_counter() - start


def time_learn(model: REINFORCE | PPO | A2C, steps: int) -> tuple[int, float]:
    """Time ``model.learn(steps)``; the step count is the model's own (it may run past ``steps``)."""
    start = time.perf_counter()
    model.learn(steps)
    return model.num_timesteps, time.perf_counter() - start


def measure(variant: str, env_id: str, n_envs: int, steps: int, seed: int) -> float:
    """Steps per second of one variant, one run."""
    env = make_env(env_id, n_envs, seed)
    try:
        if variant == "raw":
            n, seconds = time_raw(env, steps, seed)
        elif variant in ("limit", "limit_fast"):
            model = REINFORCE("MlpPolicy", env, seed=seed, device="cpu")
            if variant == "limit_fast" and not hasattr(model.policy, "fast_sampler"):
                return float("nan")
            n, seconds = time_policy_loop(env, model, steps, fast=variant == "limit_fast")
        elif variant.startswith("reinforce"):
            baseline = "value" if variant == "reinforce_value" else None
            policy_kwargs = dict(fast_rollout=False) if variant == "reinforce_sb3_sampling" else None
            model = REINFORCE("MlpPolicy", env, baseline=baseline, seed=seed, device="cpu", policy_kwargs=policy_kwargs)
            n, seconds = time_learn(model, steps)
        elif variant in ("ppo", "a2c"):
            algo: type[PPO] | type[A2C] = PPO if variant == "ppo" else A2C
            n, seconds = time_learn(algo("MlpPolicy", env, seed=seed, device="cpu"), steps)
        else:
            raise ValueError(f"unknown variant {variant!r}")
    finally:
        env.close()
    return n / seconds


def ratio(a: float, b: float) -> float:
    return a / b if b > 0 and np.isfinite(a) and np.isfinite(b) else float("nan")


def run(
    env_ids: list[str],
    n_envs_list: list[int],
    steps: int,
    repeats: int,
    threads: int,
    variants: tuple[str, ...] = VARIANTS,
    log: Callable[[str], None] = print,
) -> list[dict[str, float | int | str]]:
    """Measure every variant ``repeats`` times, interleaved, and return one row per (env, n_envs) of medians."""
    th.set_num_threads(threads)
    configs = [(env_id, n_envs) for env_id in env_ids for n_envs in n_envs_list]
    samples: dict[tuple[str, int, str], list[float]] = {(e, n, v): [] for e, n in configs for v in variants}
    for repeat in range(repeats):
        for env_id, n_envs in configs:
            for variant in variants:
                rate = measure(variant, env_id, n_envs, steps, seed=repeat)
                samples[(env_id, n_envs, variant)].append(rate)
                log(f"[repeat {repeat + 1}/{repeats}] {env_id:16s} n_envs={n_envs} {variant:16s} {rate:9.0f} steps/s")
    rows: list[dict[str, float | int | str]] = []
    for env_id, n_envs in configs:
        med = {v: statistics.median(samples[(env_id, n_envs, v)]) for v in variants}
        row: dict[str, float | int | str] = {"env_id": env_id, "n_envs": n_envs, "steps": steps, "repeats": repeats}
        row.update({f"{v}_steps_per_s": round(med[v], 1) for v in variants})
        r = med.get("reinforce", float("nan"))
        rv = med.get("reinforce_value", float("nan"))
        row.update(
            {
                "reinforce_over_raw": ratio(r, med.get("raw", float("nan"))),
                "reinforce_over_limit": ratio(r, med.get("limit", float("nan"))),
                "reinforce_over_limit_fast": ratio(r, med.get("limit_fast", float("nan"))),
                "reinforce_over_sb3_sampling": ratio(r, med.get("reinforce_sb3_sampling", float("nan"))),
                "reinforce_value_over_limit": ratio(rv, med.get("limit", float("nan"))),
                "reinforce_over_ppo": ratio(r, med.get("ppo", float("nan"))),
                "reinforce_over_a2c": ratio(r, med.get("a2c", float("nan"))),
                "reinforce_value_over_ppo": ratio(rv, med.get("ppo", float("nan"))),
                "reinforce_value_over_a2c": ratio(rv, med.get("a2c", float("nan"))),
            }
        )
        rows.append({k: round(v, 3) if isinstance(v, float) else v for k, v in row.items()})
    return rows


def print_table(rows: list[dict[str, float | int | str]], variants: tuple[str, ...]) -> None:
    head = ["env", "n", *variants, "R/raw", "R/limit", "R/lim_fast", "Rv/limit", "R/PPO", "R/A2C"]
    print(" | ".join(head))
    for row in rows:
        cells = [str(row["env_id"]), str(row["n_envs"])] + [f"{row[f'{v}_steps_per_s']:.0f}" for v in variants]
        keys = ["over_raw", "over_limit", "over_limit_fast"]
        cells += [f"{row[f'reinforce_{k}']:.2f}" for k in keys]
        cells += [f"{row['reinforce_value_over_limit']:.2f}", f"{row['reinforce_over_ppo']:.2f}"]
        cells += [f"{row['reinforce_over_a2c']:.2f}"]
        print(" | ".join(cells))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", nargs="+", default=["CartPole-v1", "LunarLander-v3"])
    parser.add_argument("--n-envs", nargs="+", type=int, default=[1, 8])
    parser.add_argument("--steps", type=int, default=4096, help="env steps per measurement (PPO: at least a rollout)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per measurement (the median is reported)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads, the same for every variant")
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--out", type=Path, default=RESULTS, help="CSV file to write")
    args = parser.parse_args(argv)

    variants = tuple(args.variants)
    rows = run(args.envs, args.n_envs, args.steps, args.repeats, args.threads, variants)
    print(f"\ntorch {th.__version__}, {args.threads} thread(s), median of {args.repeats}, {args.steps} steps each")
    print_table(rows, variants)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
