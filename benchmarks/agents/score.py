"""
Score the shipped agents as ``sb3-reinforce-zoo enjoy`` runs them: each agent's model (the final one, ``<env>.zip``,
or ``best_model.zip`` with ``--best``), its saved config and VecNormalize statistics, on evaluation seeds that no
training episode used (10,000 to 10,019 by default: training seeds its environments 0 to n_envs - 1), one
deterministic episode per seed. Prints a Markdown table and writes it as CSV.

    python benchmarks/agents/score.py --folder rl-trained-agents --out benchmarks/agents/scores.csv
"""

import argparse
import csv
from pathlib import Path

import numpy as np
from rl_zoo3.utils import create_test_env, get_saved_hyperparams
from stable_baselines3.common.vec_env import VecNormalize

from sb3_reinforce import REINFORCE


def score(folder: Path, env_id: str, seeds: list[int], best: bool) -> list[float]:
    """One deterministic episode per seed, with the agent's own test environment (as enjoy builds it)."""
    log_path = folder / "reinforce" / f"{env_id}_1"
    model_path = log_path / ("best_model.zip" if best else f"{env_id}.zip")
    hyperparams, stats_path = get_saved_hyperparams(str(log_path / env_id), norm_reward=False, test_mode=True)
    env = create_test_env(
        env_id, n_envs=1, stats_path=stats_path, seed=seeds[0], log_dir=None, should_render=False, hyperparams=hyperparams
    )
    model = REINFORCE.load(model_path, device="cpu")
    returns = []
    for seed in seeds:
        env.seed(seed)
        obs = env.reset()
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)  # type: ignore[arg-type]
            obs, reward, dones, _ = env.step(action)
            original = env.get_original_reward() if isinstance(env, VecNormalize) else reward
            total += float(original[0])
            done = bool(dones[0])
        returns.append(total)
    env.close()
    return returns


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folder", type=Path, default=Path("rl-trained-agents"))
    parser.add_argument("--envs", nargs="+", default=None, help="default: every agent in the folder")
    parser.add_argument("--first-seed", type=int, default=10_000)
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--best", action="store_true", help="score best_model.zip instead of the final model")
    parser.add_argument("--out", type=Path, default=None, help="CSV file for the table")
    args = parser.parse_args()
    envs = args.envs or sorted(p.name.rsplit("_", 1)[0] for p in (args.folder / "reinforce").iterdir() if p.is_dir())
    seeds = list(range(args.first_seed, args.first_seed + args.episodes))
    rows = []
    print(f"| env | model | episodes (seeds {seeds[0]}-{seeds[-1]}) | mean | std | min | max |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for env_id in envs:
        returns = np.array(score(args.folder, env_id, seeds, args.best))
        model = "best_model.zip" if args.best else f"{env_id}.zip"
        row = [env_id, model, len(returns), returns.mean(), returns.std(), returns.min(), returns.max()]
        rows.append(row)
        print(f"| {env_id} | {model} | {len(returns)} | " + " | ".join(f"{v:.1f}" for v in row[3:]) + " |")
    if args.out is not None:
        with args.out.open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["env", "model", "episodes", "mean", "std", "min", "max"])
            writer.writerows(rows)


if __name__ == "__main__":
    main()
