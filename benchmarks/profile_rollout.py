"""
Where REINFORCE's time goes: cProfile of ``REINFORCE.learn()``, summed into the parts of the loop.

Prints, for the fast rollout path and for SB3's sampling path (``policy_kwargs=dict(fast_rollout=False)``),
the share of the profiled time spent in: the VecEnv's ``step`` (the environment itself, its wrappers and
the DummyVecEnv copies), action sampling, the buffer's ``add``, the rest of the rollout loop
(callbacks, info buffer), and ``train()`` with ``compute_returns()`` (one gradient step per batch).
cProfile slows Python code down more than C code, so the shares are indicative; ``throughput.py`` gives rates.

Usage::

    python benchmarks/profile_rollout.py --env CartPole-v1 --n-envs 8 --steps 16384
"""

import argparse
import cProfile
import pstats

import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE

# (label, function name as pstats knows it: (file suffix, function name))
PARTS = [
    ("VecEnv.step (environment)", ("base_vec_env.py", "step")),
    ("sampling: FastSampler", ("sampling.py", "__call__")),
    ("sampling: SB3 get_distribution", ("policies.py", "get_distribution")),
    ("buffer add", ("buffers.py", "add")),
    ("train (one gradient step)", ("reinforce.py", "train")),
    ("compute_returns", ("buffers.py", "compute_returns")),
]


def profile(env_id: str, n_envs: int, steps: int, fast_rollout: bool, seed: int) -> tuple[dict[str, float], float, int]:
    """Profile one ``learn(steps)``; return the cumulative seconds of each part, the total, and the updates."""
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed, vec_env_cls=DummyVecEnv)
    model = REINFORCE("MlpPolicy", env, seed=seed, device="cpu", policy_kwargs=dict(fast_rollout=fast_rollout))
    profiler = cProfile.Profile()
    profiler.enable()
    model.learn(steps)
    profiler.disable()
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    cumulative: dict[str, float] = {}
    total = 0.0
    for (filename, _, name), (_, _, _, cumtime, callers) in stats.items():
        if filename.endswith("on_policy_algorithm.py") and name == "learn":
            total = cumtime
        for label, (suffix, function) in PARTS:
            if filename.endswith(suffix) and name == function:
                # Only the calls made by the rollout loop or by learn() (train() calls get_distribution too)
                from_loop = [c[3] for (_, _, caller), c in callers.items() if caller in ("collect_rollouts", "learn")]
                cumulative[label] = cumulative.get(label, 0.0) + sum(from_loop)
    return cumulative, total, model._n_updates


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="CartPole-v1")
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--steps", type=int, default=16_384)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    th.set_num_threads(1)
    for fast_rollout in (True, False):
        parts, total, n_updates = profile(args.env, args.n_envs, args.steps, fast_rollout, args.seed)
        name = "fast rollout path" if fast_rollout else "SB3 sampling path (fast_rollout=False)"
        print(f"\n{args.env}, n_envs={args.n_envs}, {args.steps} steps, {name}: {total:.2f} s profiled, {n_updates} updates")
        for label, _ in PARTS:
            if parts.get(label, 0.0) > 0:
                print(f"  {label:34s} {parts[label]:7.2f} s  {100 * parts[label] / total:5.1f} %")
        rest = total - sum(parts.values())
        print(f"  {'rest (loop, checks, callbacks, ...)':34s} {rest:7.2f} s  {100 * rest / total:5.1f} %")


if __name__ == "__main__":
    main()
