"""
The rule of the CarRacing-v3 tuning studies (``benchmarks/results/carracing_tuning/README.md`` and
``carracing_study2/README.md``, each committed before its runs), applied to the evaluations so far: each seed's
score, each config's score per stage, and what the rule says next.

    python benchmarks/carracing_tuning.py
    python benchmarks/carracing_tuning.py --study carracing_study2

A seed's score is the mean of its deterministic evaluations at 900k, 950k and 1M steps; a config's score is the
lowest of its seeds' scores, its mean over seeds breaking ties closer than 10 points. Stage 1 ranks the study's
candidates on seeds 100-101 beside ``a_entry``'s runs (the control: the pilot's, and the first study's on 102-103);
the best two run on seeds 102-103 (stage 2); the pick is the better of those two over the four seeds. Nothing is
decided while a run of the stage is short of 1M steps, unless that run cannot change the stage's two best: a config's
score can only fall as its seeds finish, so one whose seeds so far score 10 or more below two finished configs is
out of the two best whatever its other seeds do (its missing runs are then named and not waited for). For the same
reason the pick can be certain before the stages finish: a config finished on seeds 100-103 that at most one other
config can still pass in stage 1, and whose lowest over the four seeds is 10 or more above every other config's lowest
seed so far, wins stage 2 against any partner; the runs still awaited are then named and not waited for.
"""

import argparse
import functools
import math
from pathlib import Path
from typing import NamedTuple

import pandas as pd
from pilot_scores import evaluations_at

RESULTS = Path(__file__).parent / "results"
SCORED_STEPS = (900_000, 950_000, 1_000_000)
STAGE_1_SEEDS = (100, 101)
STAGE_2_SEEDS = (102, 103)
TIE = 10.0
#: The control, the zoo entry: its seeds 100-101 are the pilot's runs of the same config, 102-103 the first study's
CONTROL = [RESULTS / "carracing_pilot" / "b_value20", RESULTS / "carracing_tuning" / "a_entry"]


class Study(NamedTuple):
    """A study's configs (each with its comparison folders, the control among them) and where its pick goes next."""

    config_folders: dict[str, list[Path]]
    #: The fresh seeds the pick is verified on
    verification: str
    #: Whether the pick is verified when it is the control (the first study's rule) or nothing more runs (study 2's)
    control_verified: bool


def _study(name: str, candidates: tuple[str, ...], verification: str, control_verified: bool) -> Study:
    folders = {"a_entry": CONTROL, **{candidate: [RESULTS / name / candidate] for candidate in candidates}}
    return Study(folders, verification, control_verified)


STUDIES = {
    "carracing_tuning": _study("carracing_tuning", ("b_gsde", "c_gsde_squash", "d_lin_lr"), "5000-5002", True),
    "carracing_study2": _study("carracing_study2", ("b_std005", "c_clip05", "d_e8"), "6010-6012 at 4M steps", False),
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
    not yet at 1M steps (a config is scored only when none is missing), and ``lowest_so_far``, the lowest score of its
    seeds at 1M steps (NaN when none is): an upper bound on its ``lowest`` once all are.
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
                "lowest_so_far": scores.min() if done else math.nan,
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


def out_of_the_best(stage: pd.DataFrame, places: int) -> list[str]:
    """
    The unfinished configs that cannot be among the stage's ``places`` best: their lowest seed so far is at least
    ``TIE`` below the lowest of ``places`` finished configs, and a lowest score can only fall as more seeds finish.
    """
    finished = stage.loc[stage["missing"] == "", "lowest"]
    return [
        row["config"]
        for _, row in stage.iterrows()
        if row["missing"] and (finished - row["lowest_so_far"] >= TIE).sum() >= places  # NaN so far: never out
    ]


def _waiting(stage: pd.DataFrame) -> str:
    """The runs a stage still waits for, by config ("" when none)."""
    return "; ".join(f"{row['config']} seeds {row['missing']}" for _, row in stage.iterrows() if row["missing"])


def certain_pick(seeds: pd.DataFrame, configs: list[str]) -> str | None:
    """
    The config the rule picks whatever the unfinished runs give, or None. It is finished on seeds 100-103; at most one
    other config can still rank above it in stage 1 (the others' lowest seed so far is ``TIE`` or more below its
    stage-1 lowest), so it runs in stage 2; and every other config's lowest seed so far on seeds 100-103 is ``TIE`` or
    more below its lowest over the four, so it wins stage 2 against any partner (a lowest score can only fall).
    """
    stage_1 = config_scores(seeds, configs, STAGE_1_SEEDS).set_index("config")
    four = config_scores(seeds, configs, STAGE_1_SEEDS + STAGE_2_SEEDS).set_index("config")
    for pick in configs:
        if four.loc[pick, "missing"]:
            continue
        others = [config for config in configs if config != pick]
        # a config with no finished seed has a NaN lowest so far, which compares False: it can still rank anywhere
        can_pass = sum(not stage_1.loc[pick, "lowest"] - stage_1.loc[other, "lowest_so_far"] >= TIE for other in others)
        beats_all = all(four.loc[pick, "lowest"] - four.loc[other, "lowest_so_far"] >= TIE for other in others)
        if can_pass <= 1 and beats_all:
            return pick
    return None


def _after_the_pick(pick: str, lowest: float, study: Study) -> str:
    """What runs once ``pick`` is picked with ``lowest`` as its score."""
    if pick == "a_entry" and not study.control_verified:
        return "The pick is the entry: nothing more runs (its own verification at 4M: verify_carracing_4m)"
    if lowest < 500:
        return f"No config's score reaches 500; the pick is verified on seeds {study.verification} all the same"
    return f"The pick is verified on seeds {study.verification}"


def _decided_early(seeds: pd.DataFrame, study: Study, waiting: str) -> list[str]:
    """The lines that replace a stage's 'undecided' when the pick is certain already (none when it is not)."""
    pick = certain_pick(seeds, list(study.config_folders))
    if pick is None:
        return []
    best = config_scores(seeds, [pick], STAGE_1_SEEDS + STAGE_2_SEEDS).iloc[0]
    return [
        f"Decided before its runs finish: the pick is {pick} (lowest {best['lowest']:.1f}, mean {best['mean']:.1f} over "
        f"seeds 100-103), {TIE:g} or more above every other config's lowest seed so far, and a score can only fall",
        f"Not needed (they cannot change the pick): {waiting}",
        _after_the_pick(pick, best["lowest"], study),
    ]


def verdict(seeds: pd.DataFrame, study: Study) -> list[str]:
    """What ``study``'s rule says now, line by line: each stage's ranking, or what it waits for."""
    stage_1 = config_scores(seeds, list(study.config_folders), STAGE_1_SEEDS)
    out = out_of_the_best(stage_1, places=2)
    in_the_running = stage_1[~stage_1["config"].isin(out)]
    if waiting := _waiting(in_the_running):
        if early := _decided_early(seeds, study, _waiting(stage_1)):
            return early
        return [f"Stage 1 (seeds 100-101): undecided, waiting for {waiting}"]
    ranking = better_first(in_the_running)
    shown = " > ".join(ranking) + "".join(f" > {config} (out)" for config in out)
    lines = [f"Stage 1 (seeds 100-101): {shown}; stage 2 runs {ranking[0]} and {ranking[1]}"]
    if out:
        skipped = _waiting(stage_1[stage_1["config"].isin(out)])
        lines.append(f"Not needed ({TIE:g} or more below two finished configs already, and a score can only fall): {skipped}")
    stage_2 = config_scores(seeds, ranking[:2], STAGE_1_SEEDS + STAGE_2_SEEDS)
    if waiting := _waiting(stage_2):
        return [
            *lines,
            *(_decided_early(seeds, study, waiting) or [f"Stage 2 (seeds 100-103): undecided, waiting for {waiting}"]),
        ]
    pick = better_first(stage_2)[0]
    best = stage_2.set_index("config").loc[pick]
    lines.append(f"Stage 2 (seeds 100-103): the pick is {pick} (lowest {best['lowest']:.1f}, mean {best['mean']:.1f})")
    lines.append(_after_the_pick(pick, stage_2["lowest"].max(), study))
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--study", choices=sorted(STUDIES), default="carracing_tuning")
    args = parser.parse_args(argv)
    study = STUDIES[args.study]
    seeds = seed_scores(study.config_folders)
    with pd.option_context("display.width", 200, "display.max_rows", None, "display.float_format", "{:.1f}".format):
        print(seeds.to_string(index=False))
    print("\n".join(verdict(seeds, study)))


if __name__ == "__main__":
    main()
