"""
How a trained CarRacing-v3 REINFORCE policy drives when it acts by its mean action, by the mean of its clipped
sampled actions, and by sampling: issue 63's question of why its deterministic evaluations score below its sampled
ones.

CarRacing's gas and brake lie in [0, 1] and the environment clips each action into its box. SB3's deterministic
action is ``clip(mean)``; the trained policy acts, on average, as ``E[clip(a)]`` with ``a ~ N(mean, std)``, which for
a brake whose mean lies a little below 0 is a light brake where ``clip(mean)`` never brakes. This script plays the
same tracks (the evaluation env of a compare run of the entry, reseeded per episode) with a checkpoint's policy in
three ways and writes one row per episode:

- ``mean``: ``clip(mean)``, what ``predict(deterministic=True)`` and every deterministic evaluation use;
- ``expected_clipped``: ``E[clip(a)]``, in closed form for the Gaussian (no sampling);
- ``sampled``: ``clip(a)``, the training episodes' actions.

    python benchmarks/carracing_expected_action.py \
        benchmarks/results/verify_carracing_4m/per_run/reinforce_seed6002.checkpoint.zip --episodes 5
    # a checkpoint from the history (its .json beside it)
    git show 98f6c9e:benchmarks/results/verify_carracing_4m/per_run/reinforce_seed6000.checkpoint.zip > /tmp/c.zip
    git show 98f6c9e:benchmarks/results/verify_carracing_4m/per_run/reinforce_seed6000.checkpoint.json > /tmp/c.json
    python benchmarks/carracing_expected_action.py /tmp/c.zip --label 98f6c9e:reinforce_seed6000.checkpoint.zip
"""

import argparse
import csv
import json
import tempfile
from pathlib import Path

import numpy as np
import torch as th
from scipy.stats import norm

from sb3_reinforce.lab.compare.experiment import build_run

RESULTS = Path(__file__).parent / "results" / "verify_carracing_4m" / "expected_action.csv"
MODES = ("mean", "expected_clipped", "sampled")
COLUMNS = ["checkpoint", "seed", "steps", "mode", "episode", "track_seed", "return", "mean_brake_taken"]
#: The tracks: evaluation episodes are reseeded TRACK_SEED + episode, the same for every mode
TRACK_SEED = 20_000


def expected_clipped(mean: np.ndarray, std: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``E[clip(a, low, high)]`` for ``a ~ N(mean, std)``, per dimension."""
    below, above = (low - mean) / std, (high - mean) / std
    inside = mean * (norm.cdf(above) - norm.cdf(below)) + std * (norm.pdf(below) - norm.pdf(above))
    return low * norm.cdf(below) + high * norm.sf(above) + inside


def play(checkpoint: Path, episodes: int, label: str) -> list[dict[str, object]]:
    """One row per episode and mode, the checkpoint's policy in the evaluation env that compare builds for its run."""
    counters = json.loads(checkpoint.with_suffix(".json").read_text())
    seed = counters["spec"]["seed"]
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        built = build_run("reinforce", "CarRacing-v3", seed, 1000, Path(folder))
        model, env = built.model, built.eval_env
        model.set_parameters(str(checkpoint), device="cpu")
        low, high = env.action_space.low, env.action_space.high
        rng = np.random.default_rng(seed)
        try:
            for mode in MODES:
                for episode in range(episodes):
                    env.seed(TRACK_SEED + episode)
                    obs, done, brakes, info = env.reset(), False, [], {}
                    while not done:
                        with th.no_grad():
                            distribution = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0]).distribution
                            mean, std = distribution.mean.numpy()[0], distribution.stddev.numpy()[0]
                        if mode == "mean":
                            action = np.clip(mean, low, high)
                        elif mode == "expected_clipped":
                            action = expected_clipped(mean, std, low, high)
                        else:
                            action = np.clip(rng.normal(mean, std), low, high)
                        brakes.append(float(action[2]))
                        obs, _, dones, infos = env.step(action[None].astype(np.float32))
                        done, info = bool(dones[0]), infos[0]
                    rows.append(
                        {
                            "checkpoint": label,
                            "seed": seed,
                            "steps": counters["counters"]["steps"],
                            "mode": mode,
                            "episode": episode,
                            "track_seed": TRACK_SEED + episode,
                            "return": round(float(info["episode"]["r"]), 1),  # Monitor's, before any normalization
                            "mean_brake_taken": round(float(np.mean(brakes)), 4),
                        }
                    )
                    print(*rows[-1].values(), sep="\t", flush=True)
        finally:
            built.train_env.close()
            env.close()
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint", type=Path, help="a compare run's checkpoint (.zip, its .json beside it)")
    parser.add_argument("--episodes", type=int, default=5, help="episodes per mode (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="CSV to append the rows to (default: %(default)s)")
    where = "the checkpoint column's text (default: the file's name; e.g. COMMIT:NAME for one taken from history)"
    parser.add_argument("--label", type=str, default=None, help=where)
    args = parser.parse_args(argv)
    th.set_num_threads(1)
    rows = play(args.checkpoint, args.episodes, args.label or args.checkpoint.name)
    new = not args.out.exists()
    with args.out.open("a", newline="") as file:
        writer = csv.DictWriter(file, COLUMNS)
        if new:
            writer.writeheader()
        writer.writerows(rows)
    for mode in MODES:
        returns = [row["return"] for row in rows if row["mode"] == mode]
        print(f"{mode}: mean return {np.mean(returns):.1f} over {len(returns)} episodes")
    print(f"Saved {args.out}")


if __name__ == "__main__":
    main()
