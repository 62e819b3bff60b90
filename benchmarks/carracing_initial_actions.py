"""
The actions of each CarRacing tuning config's untrained policy (``benchmarks/configs/carracing_tuning/``), on the
first observations of a run's training environments: the deterministic action and the mean of sampled ones, and
how often the brake is pressed (above 0.1). A squashed Gaussian puts its mean action at the middle of the action
box, and CarRacing's gas and brake lie in [0, 1]: the results folder's README reads this to explain ``c_gsde_squash``.

    python benchmarks/carracing_initial_actions.py --seed 100 --samples 50
"""

import argparse
import csv
import tempfile
from pathlib import Path

import numpy as np

from sb3_reinforce.lab.compare.experiment import build_run

CONFIGS = Path(__file__).parent / "configs" / "carracing_tuning"
RESULTS = Path(__file__).parent / "results" / "carracing_tuning" / "initial_actions.csv"
COLUMNS = ["config", "seed", "samples", "action", "deterministic", "sampled_mean", "sampled_above_0.1"]
ACTIONS = ("steer", "gas", "brake")


def initial_actions(config: Path, seed: int, samples: int) -> list[dict[str, object]]:
    """One row per action dimension of ``config``'s untrained policy, built as a compare run of ``seed`` builds it."""
    with tempfile.TemporaryDirectory() as folder:
        built = build_run("reinforce", "CarRacing-v3", seed, 1000, Path(folder), config)
        try:
            obs = built.train_env.reset()
            deterministic = built.model.predict(obs, deterministic=True)[0][0]
            sampled = []
            for _ in range(samples):
                if built.model.use_sde:
                    built.model.policy.reset_noise(built.train_env.num_envs)
                sampled.append(built.model.predict(obs, deterministic=False)[0][0])
        finally:
            built.train_env.close()
            built.eval_env.close()
    actions = np.stack(sampled)
    return [
        {
            "config": config.stem,
            "seed": seed,
            "samples": samples,
            "action": name,
            "deterministic": round(float(deterministic[i]), 3),
            "sampled_mean": round(float(actions[:, i].mean()), 3),
            "sampled_above_0.1": round(float((actions[:, i] > 0.1).mean()), 3),
        }
        for i, name in enumerate(ACTIONS)
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--samples", type=int, default=50, help="sampled actions per config (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows = [row for config in sorted(CONFIGS.glob("*.yml")) for row in initial_actions(config, args.seed, args.samples)]
    with args.out.open("w", newline="") as file:
        writer = csv.DictWriter(file, COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    for row in rows:
        print(*(row[column] for column in COLUMNS), sep="\t")
    print(f"Saved {args.out}")


if __name__ == "__main__":
    main()
