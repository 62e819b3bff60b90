"""
The MuJoCo tuning study's rule (``benchmarks/results/mujoco_tuning/README.md``, committed before its runs), applied to
the evaluations so far: each (candidate, env)'s figures over the tuning seeds, and each env's pick once decided.

    python benchmarks/mujoco_tuning.py [--study benchmarks/results/mujoco_tuning]

A candidate's score on an env is Tianshou's metric over seeds 100 and 101 (the best mean over seeds of the
deterministic evaluations, :func:`~sb3_reinforce.lab.compare.figures.best_mean`); the highest wins, except that two
within 2% of the env's threshold's magnitude are ranked by the mean over the two seeds of their last five evaluations
(2.8M to 3M steps), and a tie on both goes to the first in ``CANDIDATES``' order. An env is decided once all three
candidates reached 3M steps on both seeds, except that an env of ``STAGE_2`` whose stage-1 pick stays below its
threshold is decided by the same rule over stage 1's and stage 2's candidates together, once those have reached 3M
steps too. Where the untrained policy's deterministic evaluation (at step 0) is already at or above the threshold on
both seeds (Ant-v4), that figure cannot say whether a pick stays below the threshold: there the stage-2
trigger, and a stage 2's pick, read the sampled-action evaluations instead. An env of ``REOPENED`` consults its
stage 2 whatever stage 1's pick scored on the tuning seeds (Swimmer-v4: the README's section written after its
verification stayed below the threshold).
"""

import argparse
from collections.abc import Collection
from pathlib import Path

import numpy as np
import pandas as pd

from sb3_reinforce.lab.compare.figures import best_mean

STUDY = Path(__file__).parent / "results" / "mujoco_tuning"
CANDIDATES = ("a_value4", "b_value4_lr3", "c_value8")
#: Stage 2 (the README's, written before its runs): its candidates per env, run only if the env's stage-1 pick stays
#: below the threshold on the tuning seeds
STAGE_2 = {
    "Swimmer-v4": ("d_gamma999", "e_gamma9999", "f_gamma9999_lr3"),
    "Ant-v4": ("g_logstd1", "h_logstd1_lr3", "i_logstd15"),
}
#: The envs whose stage-1 pick, verified on fresh seeds, stayed below the threshold, for which the README (a section
#: written after that verification, before any run it orders) has stage 2 run whatever the pick scored on the tuning
#: seeds. A record of that decision, not read off the verification folders: a stage-2 pick's own verification,
#: replacing the row there, must not undo the decision that chose it.
REOPENED = frozenset({"Swimmer-v4"})
SEEDS = (100, 101)
BUDGET = 3_000_000
TIE_SHARE = 0.02
LAST = 5


def candidate_scores(study: Path) -> pd.DataFrame:
    """
    One row per (env, candidate) with runs: the steps each seed reached, whether both finished, the lower of the seeds'
    deterministic evaluations at step 0 (the untrained policy's), the best mean over seeds of the deterministic and of
    the sampled-action evaluations, and the mean over seeds of the last five evaluations, deterministic and sampled.
    """
    thresholds = _thresholds(study)
    rows = []
    for candidate in dict.fromkeys(CANDIDATES + sum(STAGE_2.values(), ())):
        for folder in sorted((study / candidate).glob("*-v*")):
            runs = [pd.read_csv(path) for path in sorted((folder / "per_run").glob("reinforce_seed*.csv"))]
            runs = [run for run in runs if int(run["seed"].iloc[0]) in SEEDS and len(run)]
            if not runs:
                continue
            frame = pd.concat(runs)
            row: dict[str, object] = {"env": folder.name, "candidate": candidate, "threshold": thresholds.get(folder.name)}
            row["steps"] = " / ".join(f"{int(run['steps'].max()):,}" for run in runs)
            row["finished"] = len(runs) == len(SEEDS) and all(run["steps"].max() >= BUDGET for run in runs)
            row["untrained"] = min(float(run.loc[run["steps"] == 0, "mean_return"].min()) for run in runs)
            row["best mean"] = best_mean(frame, "mean_return")[0]
            row["best mean, sampled"] = best_mean(frame, "mean_return_stochastic")[0]
            row["last 5 mean"] = float(np.mean([run["mean_return"].iloc[-LAST:].mean() for run in runs]))
            row["last 5 mean, sampled"] = float(np.mean([run["mean_return_stochastic"].iloc[-LAST:].mean() for run in runs]))
            rows.append(row)
    return pd.DataFrame(rows)


def _thresholds(study: Path) -> dict[str, float]:
    """Each env's threshold, as its comparisons recorded it (``comparison.json``, written by run.sh's --threshold)."""
    found = {}
    for meta in study.glob("*/*/comparison.json"):
        table = pd.read_json(meta, typ="series")
        found[str(table["env"])] = float(table["threshold"])
    return found


def pick(scores: pd.DataFrame, env: str, reopened: Collection[str] = REOPENED) -> str | None:
    """
    The rule's pick on ``env``, or None until every candidate it needs finished on both seeds: stage 1's, and
    stage 2's too where the env has one and either is in ``reopened`` or its stage-1 pick stays below the threshold
    (by the sampled-action figure where the untrained policy's deterministic one already reaches the threshold, which
    then also decides stage 2).

    :param scores: :func:`candidate_scores`'s table
    :param env: The env id
    :param reopened: The envs whose stage 2 runs whatever their stage-1 pick scored (``REOPENED``)
    """
    chosen = _best(scores, env, CANDIDATES)
    if chosen is None or env not in STAGE_2:
        return chosen
    row = scores[(scores["env"] == env) & (scores["candidate"] == chosen)].iloc[0]
    sampled = bool(row["untrained"] >= row["threshold"])
    below = env in reopened or row["best mean, sampled" if sampled else "best mean"] < row["threshold"]
    return _best(scores, env, CANDIDATES + STAGE_2[env], sampled) if below else chosen


def _best(scores: pd.DataFrame, env: str, candidates: tuple[str, ...], sampled: bool = False) -> str | None:
    """The rule over ``candidates`` on ``env``, on the deterministic or the sampled-action figures (None until all of
    them finished on both seeds)."""
    rows = scores[(scores["env"] == env) & scores["candidate"].isin(candidates)]
    if set(rows["candidate"]) != set(candidates) or not rows["finished"].all():
        return None
    best_mean, last = ("best mean, sampled", "last 5 mean, sampled") if sampled else ("best mean", "last 5 mean")
    rows = rows.set_index("candidate").loc[list(candidates)].reset_index()  # the candidates' order: a full tie's pick
    ranked = rows.sort_values(best_mean, ascending=False, kind="stable")
    best, second = ranked.iloc[0], ranked.iloc[1] if len(ranked) > 1 else None
    tie = TIE_SHARE * abs(float(best["threshold"]))
    if second is not None and best[best_mean] - second[best_mean] <= tie:
        contenders = ranked[ranked[best_mean] >= best[best_mean] - tie]
        return str(contenders.sort_values(last, ascending=False, kind="stable").iloc[0]["candidate"])
    return str(best["candidate"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--study", type=Path, default=STUDY)
    args = parser.parse_args()
    scores = candidate_scores(args.study)
    if scores.empty:
        print("no runs yet")
        return
    print(scores.to_string(index=False, float_format=lambda x: f"{x:,.1f}"))
    for env in dict.fromkeys(scores["env"]):
        chosen = pick(scores, env)
        print(f"{env}: " + (f"pick {chosen}" if chosen else "undecided (a candidate it needs is short of 3M on a seed)"))


if __name__ == "__main__":
    main()
