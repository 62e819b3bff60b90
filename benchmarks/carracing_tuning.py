"""
The CarRacing-v3 tuning study's rule (``benchmarks/results/carracing_tuning/README.md``, committed before its runs),
applied to the evaluations so far: each seed's score, each config's score per stage, and what the rule says next.

    python benchmarks/carracing_tuning.py

A seed's score is the mean of its deterministic evaluations at 900k, 950k and 1M steps; a config's score is the
lowest of its seeds' scores, its mean over seeds breaking ties closer than 10 points. Stage 1 ranks ``b``, ``c``
and ``d`` on seeds 100-101 beside ``a_entry``'s pilot runs; the best two run on seeds 102-103 (stage 2); the pick
is the better of those two over the four seeds. Nothing is decided while a run of the stage is short of 1M steps.
"""

import argparse
import functools
import math
from pathlib import Path

import pandas as pd
from pilot_scores import evaluations_at

RESULTS = Path(__file__).parent / "results"
STUDY = RESULTS / "carracing_tuning"
SCORED_STEPS = (900_000, 950_000, 1_000_000)
STAGE_1_SEEDS = (100, 101)
STAGE_2_SEEDS = (102, 103)
TIE = 10.0
# Each config's comparison folders; the control's seeds 100-101 are the pilot's runs of the same config
CONFIG_FOLDERS = {
    "a_entry": [RESULTS / "carracing_pilot" / "b_value20", STUDY / "a_entry"],
    "b_gsde": [STUDY / "b_gsde"],
    "c_gsde_squash": [STUDY / "c_gsde_squash"],
    "d_lin_lr": [STUDY / "d_lin_lr"],
}


def seed_scores(config_folders: dict[str, list[Path]]) -> pd.DataFrame:
    """
    One row per (config, seed) found: the steps reached, the deterministic evaluations at 900k, 950k and 1M steps
    (NaN where not reached yet) and their mean, the seed's score (NaN until all three exist).
    """
    rows = []
    for config, folders in config_folders.items():
        for folder in folders:
            for path in sorted((folder / "per_run").glob("reinforce_seed*.csv")):
                run = pd.read_csv(path)
                evaluations = evaluations_at(run, SCORED_STEPS)
                row = {"config": config, "seed": int(run["seed"].iloc[0]), "steps": int(run["steps"].max())}
                row.update({f"{steps // 1000}k": value for steps, value in zip(SCORED_STEPS, evaluations, strict=True)})
                row["score"] = sum(evaluations) / len(evaluations)  # NaN while one is missing
                rows.append(row)
    columns = ["config", "seed", "steps", *(f"{steps // 1000}k" for steps in SCORED_STEPS), "score"]
    return pd.DataFrame(rows, columns=columns)


def config_scores(seeds: pd.DataFrame, configs: list[str], stage_seeds: tuple[int, ...]) -> pd.DataFrame:
    """
    Each config's score over ``stage_seeds``: the lowest seed score and the mean, with ``missing`` naming the seeds
    not yet at 1M steps (a config is scored only when none is missing).
    """
    rows = []
    for config in configs:
        own = seeds[(seeds["config"] == config) & seeds["seed"].isin(stage_seeds)].set_index("seed")
        done = [seed for seed in stage_seeds if seed in own.index and not math.isnan(own.loc[seed, "score"])]
        missing = [
            f"{seed} ({int(own.loc[seed, 'steps']):,} steps)" if seed in own.index else f"{seed} (not started)"
            for seed in stage_seeds
            if seed not in done
        ]
        scores = own.loc[done, "score"] if done else pd.Series(dtype=float)
        rows.append(
            {
                "config": config,
                "lowest": scores.min() if not missing else math.nan,
                "mean": scores.mean() if not missing else math.nan,
                "missing": ", ".join(missing),
            }
        )
    return pd.DataFrame(rows)


def better_first(scored: pd.DataFrame) -> list[str]:
    """The scored configs, best first: the higher lowest score, or the higher mean when the lowest are within 10."""

    def compare(a: pd.Series, b: pd.Series) -> int:
        if abs(a["lowest"] - b["lowest"]) < TIE:
            return -1 if a["mean"] > b["mean"] else 1 if a["mean"] < b["mean"] else 0
        return -1 if a["lowest"] > b["lowest"] else 1

    rows = [row for _, row in scored.iterrows()]
    return [row["config"] for row in sorted(rows, key=functools.cmp_to_key(compare))]


def _waiting(stage: pd.DataFrame) -> str:
    """The runs a stage still waits for, by config ("" when none)."""
    return "; ".join(f"{row['config']} seeds {row['missing']}" for _, row in stage.iterrows() if row["missing"])


def verdict(seeds: pd.DataFrame) -> list[str]:
    """What the rule says now, line by line: each stage's ranking, or what it waits for."""
    stage_1 = config_scores(seeds, list(CONFIG_FOLDERS), STAGE_1_SEEDS)
    if waiting := _waiting(stage_1):
        return [f"Stage 1 (seeds 100-101): undecided, waiting for {waiting}"]
    ranking = better_first(stage_1)
    lines = [f"Stage 1 (seeds 100-101): {' > '.join(ranking)}; stage 2 runs {ranking[0]} and {ranking[1]}"]
    stage_2 = config_scores(seeds, ranking[:2], STAGE_1_SEEDS + STAGE_2_SEEDS)
    if waiting := _waiting(stage_2):
        return [*lines, f"Stage 2 (seeds 100-103): undecided, waiting for {waiting}"]
    pick = better_first(stage_2)[0]
    best = stage_2.set_index("config").loc[pick]
    lines.append(f"Stage 2 (seeds 100-103): the pick is {pick} (lowest {best['lowest']:.1f}, mean {best['mean']:.1f})")
    if stage_2["lowest"].max() < 500:
        lines.append("No config's score reaches 500; the pick is verified on seeds 5000-5002 all the same")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.parse_args(argv)
    seeds = seed_scores(CONFIG_FOLDERS)
    with pd.option_context("display.width", 200, "display.max_rows", None, "display.float_format", "{:.1f}".format):
        print(seeds.to_string(index=False))
    print("\n".join(verdict(seeds)))


if __name__ == "__main__":
    main()
