"""
The rollout's action sampler against SB3's own path, per call (issue 46).

REINFORCE's rollout samples with :class:`~sb3_reinforce.reinforce.sampling.FastSampler` (NumPy forward pass of the
actor, noise from torch's generator). SB3's path is ``policy.get_distribution(obs).get_actions()`` under
``torch.inference_mode()``, here with ``torch.distributions``' argument validation off (its fastest setting).
Both are timed interleaved in one process, on the same policy and observations, for a categorical (CartPole-v1)
and a Gaussian (HalfCheetah-like 17 -> 6) policy, 1 and 8 environments.

Usage: python benchmarks/sampler_cost.py [--calls N] [--out CSV]
"""

import argparse
import time

import numpy as np
import pandas as pd
import torch as th
from gymnasium import spaces
from torch.distributions import Distribution

from sb3_reinforce.reinforce.policies import ReinforcePolicy
from sb3_reinforce.reinforce.sampling import FastSampler


def sb3_sampler(policy: ReinforcePolicy):
    def sample(obs: np.ndarray) -> np.ndarray:
        with th.inference_mode():
            return policy.get_distribution(th.as_tensor(obs)).get_actions().numpy()

    return sample


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--calls", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    th.set_num_threads(1)
    Distribution.set_default_validate_args(False)
    cases = {
        "categorical 4->2 (CartPole)": (spaces.Box(-1, 1, (4,), np.float32), spaces.Discrete(2)),
        "gaussian 17->6 (HalfCheetah)": (spaces.Box(-1, 1, (17,), np.float32), spaces.Box(-1, 1, (6,), np.float32)),
    }
    rows = []
    for name, (obs_space, action_space) in cases.items():
        policy = ReinforcePolicy(obs_space, action_space, lambda _: 1e-3, value_head=False)
        for n_envs in (1, 8):
            obs = np.stack([obs_space.sample() for _ in range(n_envs)])
            samplers = {"FastSampler": FastSampler(policy), "SB3 get_distribution": sb3_sampler(policy)}
            times: dict[str, list[float]] = {key: [] for key in samplers}
            for _ in range(args.repeats):  # interleaved: each repeat times both
                for key, sampler in samplers.items():
                    start = time.perf_counter()
                    for _ in range(args.calls):
                        sampler(obs)
                    times[key].append((time.perf_counter() - start) / args.calls * 1e6)
            fast, sb3 = min(times["FastSampler"]), min(times["SB3 get_distribution"])
            rows.append(dict(case=name, n_envs=n_envs, fast_us=fast, sb3_us=sb3, ratio=sb3 / fast))
            print(f"{name:32s} n_envs={n_envs}: FastSampler {fast:6.1f} us, SB3 {sb3:6.1f} us per call: {sb3 / fast:.1f}x")
    if args.out:
        pd.DataFrame(rows).to_csv(args.out, index=False)


if __name__ == "__main__":
    main()
