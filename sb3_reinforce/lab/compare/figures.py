"""Tables and plots of comparisons (from ``results.csv`` and run summaries) and of the seed reproduction."""

from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import seaborn as sns
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FuncFormatter

from sb3_reinforce.lab.compare.folder import ComparisonFolder
from sb3_reinforce.lab.stats import (
    best_mean_over_seeds,
    bootstrap_ci,
    first_crossing,
    iqm,
    quantile_with_inf,
    rolling_mean,
)

__all__ = [
    "BAND_LABEL",
    "best_mean",
    "learning_curves",
    "overview_table",
    "plot_learning_curves",
    "plot_overview",
    "plot_seed_curves",
    "published_table",
    "seed_table",
    "summary_table",
    "to_markdown",
]

_ALGO_NAMES = {"reinforce": "REINFORCE", "ppo": "PPO", "a2c": "A2C"}


def _display_name(algo: object) -> str:
    """An algorithm's name in tables and legends (``REINFORCE``; another rl_zoo3 name upper-cased)."""
    return _ALGO_NAMES.get(str(algo), str(algo).upper())


def _median_iqr(values: Sequence[float], fmt: str = "{:,.0f}") -> str:
    values = list(values)
    if not values:
        return "-"
    reached = sum(np.isfinite(values))
    median, q25, q75 = (quantile_with_inf(values, q) for q in (0.5, 0.25, 0.75))

    def show(x: float) -> str:
        return "not reached" if np.isinf(x) else fmt.format(x)

    if reached == 0:
        return f"not reached (0/{len(values)})"
    return f"{show(median)} [{show(q25)}, {show(q75)}] ({reached}/{len(values)} reached)"


def _entry_note(algo: object, summaries: dict[tuple[str, int], dict]) -> str:
    """`` (defaults)`` for an algorithm that trained with its zoo file's ``default`` entry (none for the env), else ``""``."""
    entries = {summary.get("zoo_entry") for (name, _), summary in summaries.items() if name == algo}
    if "default" in entries:
        return " (defaults)"
    return " ('atari' entry)" if "atari" in entries else ""


def _median(values: Sequence[float], fmt: str) -> str:
    """The median over seeds of steps or seconds to the threshold, not-reached seeds counted as infinitely late."""
    median = quantile_with_inf(list(values), 0.5) if len(values) else np.inf
    return "not reached" if np.isinf(median) else fmt.format(median)


def _per_seed(algo_df: pd.DataFrame) -> tuple[list[pd.DataFrame], list[pd.DataFrame]]:
    """One algorithm's evaluations per seed, and without the untrained one (an untrained policy can score by chance)."""
    per_seed = [seed_df.sort_values("eval_index") for _, seed_df in algo_df.groupby("seed")]
    return per_seed, [df[df["eval_index"] > 0] for df in per_seed]


def _reach(trained: Sequence[pd.DataFrame], threshold: float) -> tuple[list[float], list[float]]:
    """Each seed's steps and training seconds to its first evaluation at or above ``threshold`` (inf: never)."""
    steps = [first_crossing(df["steps"], df["mean_return"], threshold) for df in trained]
    seconds = [first_crossing(df["wall_time_s"], df["mean_return"], threshold) for df in trained]
    return steps, seconds


def _finals(per_seed: Sequence[pd.DataFrame], column: str) -> list[float]:
    """Each seed's last evaluation (its final score)."""
    return [float(df[column].iloc[-1]) for df in per_seed]


def learning_curves(algo_df: pd.DataFrame, column: str = "mean_return") -> tuple[np.ndarray, pd.DataFrame]:
    """
    One algorithm's evaluations as curves.

    :return: The median steps per evaluation index, and ``column`` by evaluation index and seed (NaN: not reached yet)
    """
    table = algo_df.pivot_table(index="eval_index", columns="seed", values=column)
    return algo_df.groupby("eval_index")["steps"].median().loc[table.index].to_numpy(), table


def every_seed_reached(results: pd.DataFrame) -> pd.DataFrame:
    """
    The rows of the evaluation points every seed of their algorithm reached: what the metric reads and the curves
    draw (a run that ends a few steps past its budget has one evaluation more than another; a running one fewer).

    :param results: Evaluations of one algorithm, or of several told apart by an ``algo`` column
    """
    algos = results["algo"] if "algo" in results else pd.Series("", index=results.index)
    seeds = results.groupby(algos)["seed"].transform("nunique")
    return results[results.groupby([algos, results["eval_index"]])["seed"].transform("nunique") == seeds]


def best_mean(algo_df: pd.DataFrame, column: str) -> tuple[float, float, int]:
    """
    Tianshou's metric (:func:`~sb3_reinforce.lab.stats.best_mean_over_seeds`) over the points every seed reached.

    :param algo_df: One algorithm's rows of ``results.csv``
    :param column: ``"mean_return"`` (deterministic) or ``"mean_return_stochastic"``
    :return: (the best mean over seeds, the standard deviation over seeds there, the index of that point)
    """
    return best_mean_over_seeds(learning_curves(every_seed_reached(algo_df), column)[1].to_numpy().T)


def _shown(figure: tuple[float, float, int]) -> str:
    """A :func:`best_mean` figure as ``best ± std``."""
    return f"{figure[0]:.1f} ± {figure[1]:.1f}"


def _seed_range(seeds: Sequence[int]) -> str:
    """``1000-1009`` for consecutive seeds, else the list."""
    seeds = sorted(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds))


def _steps_short(steps: float) -> str:
    """A budget to two significant digits: ``1M`` (for 1,015,808 steps), ``500k``."""
    rounded = float(f"{steps:.2g}")
    return f"{rounded / 1e6:g}M" if rounded >= 1e6 else f"{rounded / 1e3:g}k"


def _first_of_each(folders: Sequence[Path]) -> Iterator[tuple[Path, str, float | None, str, pd.DataFrame]]:
    """
    Each environment and algorithm of comparison folders once, from the first folder holding it.

    :param folders: Comparison output folders (``sb3-reinforce compare --out``)
    :return: (folder, env id, threshold, algorithm, its rows of ``results.csv``), in the folders' order
    """
    seen: set[tuple[str, str]] = set()
    for folder in folders:
        comparison = ComparisonFolder(folder)
        results = comparison.results()
        env_id, threshold = comparison.read_meta()
        for algo, algo_df in results.groupby("algo", sort=False):
            if (env_id, str(algo)) not in seen:
                seen.add((env_id, str(algo)))
                yield Path(folder), env_id, threshold, str(algo), algo_df


def overview_table(folders: Sequence[Path]) -> pd.DataFrame:
    """
    The one-screen summary over comparisons, one row per environment and algorithm (from the first folder holding it).

    :param folders: Comparison output folders (``sb3-reinforce compare --out``), in the order of the rows
    :return: A table of strings (budget, seeds and median steps to the threshold, final IQMs, folder)
    """
    rows = []
    for folder, env_id, threshold, algo, algo_df in _first_of_each(folders):
        per_seed, trained = _per_seed(algo_df)
        row = {
            "env (threshold)": env_id if threshold is None else f"{env_id} ({threshold:g})",
            "algorithm": _display_name(algo),
            "budget": _steps_short(float(np.median([df["steps"].iloc[-1] for df in per_seed]))),
        }
        if threshold is not None:
            # No seconds: the folders' runs ran at different times on differently loaded machines, so their
            # seconds answer no question across algorithms; benchmarks/wallclock_table.py measures time side by side.
            steps_to, _ = _reach(trained, threshold)
            median_steps = quantile_with_inf(steps_to, 0.5)
            seeds = _seed_range([int(s) for s in algo_df["seed"].unique()])
            row["seeds reaching"] = f"{int(np.isfinite(steps_to).sum())}/{len(per_seed)} (seeds {seeds})"
            row["median steps to reach"] = "not reached" if np.isinf(median_steps) else f"{median_steps:,.0f}"
        row["final IQM"] = f"{iqm(_finals(per_seed, 'mean_return')):.1f}"
        if "mean_return_stochastic" in algo_df:
            row["final IQM, sampled actions"] = f"{iqm(_finals(per_seed, 'mean_return_stochastic')):.1f}"
        row["folder"] = f"`{Path(folder).as_posix().rstrip('/')}`"
        rows.append(row)
    return pd.DataFrame(rows)


def published_table(folders: Sequence[Path], published: pd.DataFrame, algo: str = "reinforce") -> pd.DataFrame:
    """
    Published results beside this package's best mean over seeds (deterministic and sampled actions), final IQM
    and seeds. A row meets a published number of the same budget only if both of its figures do (only the
    deterministic one for a source marked ``deterministic``).

    :param folders: Comparison output folders (the first that ran ``algo`` on an env is used)
    :param published: Rows of ``env_id``, ``source``, ``budget`` (steps), ``mean``, ``std`` (NaN if none) and
        optionally ``approximate`` (True: read off a plot, shown as ``~``) and ``deterministic`` (True: the source
        evaluates deterministic actions, so only the deterministic figure is held against it)
    :param algo: The algorithm of the folders to read
    :return: A table of strings, one row per env of ``published`` in order ("not measured yet" where none ran)
    """
    ours: dict[str, tuple[Path, pd.DataFrame]] = {}
    for folder, env_id, _, run_algo, algo_df in _first_of_each(folders):
        if run_algo == algo:
            ours.setdefault(env_id, (folder, algo_df))
    name = _display_name(algo)
    published = published.assign(deterministic=published.get("deterministic", False)).fillna({"deterministic": False})
    rows = []
    for env_id, env_rows in published.groupby("env_id", sort=False):
        row: dict[str, str] = {"env": env_id}
        for _, entry in env_rows.iterrows():
            figure = ("~" if entry.get("approximate", False) else "") + f"{entry['mean']:g}"
            if not pd.isna(entry["std"]):
                figure += f" ± {entry['std']:g}"
            row[f"{entry['source']}, {_steps_short(float(entry['budget']))}"] = figure
        if env_id not in ours:
            row[f"{name} here"] = "not measured yet"
            rows.append(row)
            continue
        folder, algo_df = ours[env_id]
        per_seed, _ = _per_seed(algo_df)
        budget = float(np.median([df["steps"].iloc[-1] for df in per_seed]))
        columns = ["mean_return", "mean_return_stochastic"] if "mean_return_stochastic" in algo_df else ["mean_return"]
        figures = [best_mean(algo_df, column) for column in columns]
        # The lower of the two: Tianshou evaluates sampled actions, this package deterministic ones
        best = min(figure[0] for figure in figures)
        row[f"{name} here"] = f"{_shown(figures[0])} ({_steps_short(budget)})"
        if len(figures) > 1:
            row[f"{name} here, sampled actions"] = _shown(figures[1])
        finals = _finals(per_seed, "mean_return")
        low, high = bootstrap_ci(finals, iqm)
        row["final IQM [95% CI]"] = f"{iqm(finals):.1f} [{low:.1f}, {high:.1f}]"
        row["seeds"] = _seed_range([int(seed) for seed in algo_df["seed"].unique()])
        same_budget = env_rows[env_rows["budget"].map(lambda steps: _steps_short(float(steps))) == _steps_short(budget)]
        below = [
            f"{entry['source']} ({entry['mean']:g})"
            for _, entry in same_budget.iterrows()
            # a source that evaluates deterministic actions (rl_zoo3's benchmark) meets the deterministic figure only
            if (figures[0][0] if entry["deterministic"] else best) < entry["mean"]
        ]
        row["at or above the published"] = "-" if same_budget.empty else ("yes" if not below else "below " + ", ".join(below))
        row["folder"] = f"`{Path(folder).as_posix().rstrip('/')}`"
        rows.append(row)
    return pd.DataFrame(rows).fillna("")


def summary_table(
    results: pd.DataFrame, summaries: dict[tuple[str, int], dict], threshold: float | None, compact: bool = False
) -> pd.DataFrame:
    """
    One row per algorithm: the comparison's figures over seeds (deterministic evaluation returns).

    :param results: The rows of ``results.csv``
    :param summaries: The finished runs' summaries, ``ComparisonFolder.load_summaries()`` (for steps/s and memory)
    :param threshold: The solve threshold (None: no threshold columns)
    :param compact: Short headers and medians without IQR (the terminal's table); else ``summary.md``'s
    :return: A table of strings, ready to print
    """
    rows = []
    for algo, algo_df in results.groupby("algo", sort=False):
        per_seed, trained = _per_seed(algo_df)
        finals = _finals(per_seed, "mean_return")
        low, high = bootstrap_ci(finals, iqm)
        row = {
            "algorithm": _display_name(algo) + _entry_note(algo, summaries),
            "seeds": len(per_seed),
            "steps": f"{int(np.median([df['steps'].iloc[-1] for df in per_seed])):,}",
            "final IQM [95% CI]" if compact else "final score, IQM [95% CI]": f"{iqm(finals):.1f} [{low:.1f}, {high:.1f}]",
        }
        if "mean_return_stochastic" in algo_df:
            header = "sampled" if compact else "final sampled-action score, IQM"
            row[header] = f"{iqm(_finals(per_seed, 'mean_return_stochastic')):.1f}"
        if not compact:
            row["best mean over seeds ± std"] = _shown(best_mean(algo_df, "mean_return"))
        if threshold is not None:
            steps_to, seconds_to = _reach(trained, threshold)
            if compact:
                row[f"reached {threshold:g}"] = f"{int(np.isfinite(steps_to).sum())}/{len(per_seed)}"
                row[f"steps to {threshold:g}"] = _median(steps_to, "{:,.0f}")
                row[f"s to {threshold:g}"] = _median(seconds_to, "{:,.1f}")
            else:
                row[f"steps to {threshold:g}, median [IQR]"] = _median_iqr(steps_to)
                row[f"seconds to {threshold:g}, median [IQR]"] = _median_iqr(seconds_to, "{:,.1f}")
        seeds = [int(seed) for seed in algo_df["seed"].unique()]
        sps = [summaries[(str(algo), s)]["steps_per_s"] for s in seeds if (str(algo), s) in summaries]
        rss = [summaries[(str(algo), s)]["peak_rss_mb"] for s in seeds if (str(algo), s) in summaries]
        row["steps/s" if compact else "steps/s, median"] = f"{np.median(sps):,.0f}" if sps else "-"
        row["RSS MB" if compact else "peak RSS MB, max"] = f"{max(rss):,.0f}" if rss else "-"
        cpu = [
            float(summaries[(str(algo), s)]["cpu_time_s"]) for s in seeds if "cpu_time_s" in summaries.get((str(algo), s), {})
        ]
        row["CPU s" if compact else "CPU s per run, median"] = f"{np.median(cpu):,.0f}" if cpu else "-"
        rows.append(row)
    return pd.DataFrame(rows)


def to_markdown(table: pd.DataFrame) -> str:
    """
    A GitHub markdown table.

    :param table: Any data frame
    :return: The markdown text
    """
    lines = ["| " + " | ".join(map(str, table.columns)) + " |", "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(map(str, row)) + " |" for row in table.itertuples(index=False)]
    return "\n".join(lines) + "\n"


#: What the shaded band around each curve is (named in every plot's legend).
BAND_LABEL = "band: 95% bootstrap CI of the mean over seeds"


def _band(statistic: Callable[..., float] = np.mean) -> dict[str, Callable[[np.ndarray], tuple[float, float]]]:
    """
    seaborn's band around a curve of ``statistic`` over seeds: its 95% percentile-bootstrap CI, 500 resamples, fixed
    seed (reproducible PNGs), from :func:`bootstrap_ci`, which resamples each point's seeds in one vectorized call
    (seaborn's own ``errorbar="ci"`` calls the statistic once per resample: 380,000 calls for the MuJoCo overview).
    """
    return dict(errorbar=lambda values: bootstrap_ci(values, statistic, n_resamples=500))


def _seeds_label(name: str, n_seeds: int) -> str:
    """A curve's legend entry (one seed has no band)."""
    return f"{name}: mean over {n_seeds} seeds" if n_seeds > 1 else f"{name}: 1 seed (no band)"


def _curves(results: pd.DataFrame) -> pd.DataFrame:
    """
    ``results.csv``'s rows for seaborn: :func:`every_seed_reached`'s points, steps as their median over seeds (so
    points line up), display names.
    """
    results = every_seed_reached(results)
    steps = results.groupby(["algo", "eval_index"])["steps"].transform("median")
    return results.assign(steps=steps, algorithm=results["algo"].map(_display_name))


def _finish_plot(
    fig: Figure, ax: Axes, threshold: float | None, xlabel: str, ylabel: str, title: str, path: Path, band: bool = True
) -> Figure:
    """
    Draw the threshold and legend, format and label the axes, save the PNG and close the figure.

    :return: The figure (closed: its texts can still be read)
    """
    if threshold is not None:
        ax.axhline(threshold, color="black", linestyle="--", linewidth=1, label=f"solved ({threshold:g})")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:,.0f}"))
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=[*handles, Patch(facecolor="gray", alpha=0.2, label=BAND_LABEL)] if band else handles)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


def plot_learning_curves(results: pd.DataFrame, threshold: float | None, path: Path, title: str) -> Figure:
    """
    Plot the mean deterministic evaluation return over seeds (95% bootstrap CI band) by steps, one line per algorithm.

    :param results: The rows of ``results.csv``
    :param threshold: The solve threshold (None: not drawn)
    :param path: The PNG to write
    :param title: The plot's title
    :return: The figure, saved and closed
    """
    data = _curves(results)
    seeds = data.groupby("algorithm", sort=False)["seed"].nunique()
    data["algorithm"] = data["algorithm"].map({name: _seeds_label(name, n) for name, n in seeds.items()})
    fig, ax = plt.subplots(figsize=(7, 4.5))
    sns.lineplot(data, x="steps", y="mean_return", hue="algorithm", ax=ax, **_band())
    return _finish_plot(fig, ax, threshold, "environment steps", "evaluation return (deterministic)", title, path)


def seed_table(episodes: pd.DataFrame, threshold: float, window: int = 100) -> pd.DataFrame:
    """
    The seed reproduction's figures per seed: episodes and steps until the ``window``-episode mean training return
    reaches ``threshold``, and the best and final such means (NaN with fewer than ``window`` episodes).

    :param episodes: One row per training episode (``seed``, ``episode``, ``steps``, ``episode_return``, ...)
    :param threshold: The solve threshold
    :param window: Moving-mean window, in episodes (the seed and SB3 use 100)
    :return: A table with one row per seed
    """
    rows = []
    for seed, df in episodes.groupby("seed"):
        df = df.sort_values("episode")
        moving = rolling_mean(df["episode_return"], window)
        moving[: window - 1] = -np.inf  # a full window is needed
        rows.append(
            {
                "seed": int(seed),
                "episodes": int(df["episode"].iloc[-1]),
                "steps": int(df["steps"].iloc[-1]),
                f"episodes to a {window}-episode mean of {threshold:g}": first_crossing(df["episode"], moving, threshold),
                f"steps to a {window}-episode mean of {threshold:g}": first_crossing(df["steps"], moving, threshold),
                f"best {window}-episode mean": float(np.max(moving)) if len(df) >= window else float("nan"),
                f"final {window}-episode mean": float(moving[-1]) if len(df) >= window else float("nan"),
                "wall-clock s": float(df["wall_time_s"].iloc[-1]),
            }
        )
    return pd.DataFrame(rows)


def plot_seed_curves(episodes: pd.DataFrame, threshold: float, path: Path, title: str, window: int = 100) -> Figure:
    """
    Plot the mean over seeds of the ``window``-episode moving mean training return (95% bootstrap CI band) by
    episode; one line per seed, no band, if seeds ran different numbers of episodes. Symlog y for huge returns.

    :param episodes: One row per training episode
    :param threshold: The solve threshold
    :param path: The PNG to write
    :param title: The plot's title
    :param window: Moving-mean window, in episodes
    :return: The figure, saved and closed
    """
    counts = episodes.groupby("seed")["episode"].max()
    moving = episodes.sort_values(["seed", "episode"])
    moving = moving.assign(moving=moving.groupby("seed")["episode_return"].transform(lambda x: rolling_mean(x, window)))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if counts.nunique() > 1:
        # Seeds that stopped early (--max-steps): a mean would end at the shortest one
        for seed, df in moving.groupby("seed"):
            ax.plot(df["episode"], df["moving"], label=f"seed {seed} ({len(df):,} episodes)")
    else:
        step = max(1, int(counts.iloc[0]) // 400)  # a bootstrap every `step` episodes is enough for a plot
        every = moving[(moving["episode"] - 1) % step == 0]
        label = _seeds_label("seed's agent", len(counts))
        sns.lineplot(every.assign(curve=label), x="episode", y="moving", hue="curve", ax=ax, **_band())
    if episodes["episode_return"].abs().max() > 100 * max(abs(threshold), 1.0):
        # Returns over orders of magnitude (e.g. MountainCar without a time limit)
        ax.set_yscale("symlog", linthresh=max(abs(threshold), 1.0))
    ylabel = f"training return, {window}-episode moving mean"
    return _finish_plot(fig, ax, threshold, "training episodes", ylabel, title, path, band=counts.nunique() == 1)


#: Panels per row of :func:`plot_overview`'s figure.
_OVERVIEW_COLUMNS = 4


def plot_overview(folders: Sequence[Path], path: Path) -> Figure:
    """
    One panel per environment of :func:`overview_table`, one curve per algorithm: the IQM over seeds of the
    deterministic evaluation return, with its 95% bootstrap CI band.

    :param folders: Comparison output folders, in the order of the panels
    :param path: The PNG to write
    :return: The figure, saved and closed
    """
    runs = [(env_id, threshold, algo_df) for _, env_id, threshold, _, algo_df in _first_of_each(folders)]
    data = pd.concat([_curves(algo_df).assign(env=env_id) for env_id, _, algo_df in runs])
    seeds = data.groupby(["env", "algorithm"])["seed"].transform("nunique")
    data["label"] = data["algorithm"] + " (" + seeds.astype(str) + " seeds)"  # the legend's entries, per panel
    colors = {name: f"C{i}" for i, name in enumerate(_ALGO_NAMES.values())}
    palette = dict(zip(data["label"], data["algorithm"].map(colors), strict=True))
    n_columns = min(_OVERVIEW_COLUMNS, data["env"].nunique())
    grid = sns.relplot(
        data, x="steps", y="mean_return", col="env", col_wrap=n_columns, hue="label", palette=palette, kind="line",
        estimator=iqm, height=3.3, aspect=4.2 / 3.3, facet_kws=dict(sharex=False, sharey=False), legend=False, **_band(iqm),
    )  # fmt: skip
    thresholds = {env_id: threshold for env_id, threshold, _ in runs}
    for env_id, ax in grid.axes_dict.items():
        threshold = thresholds[env_id]
        handles = [
            Line2D([], [], color=palette[label], label=label) for label in data[data["env"] == env_id]["label"].unique()
        ]
        if threshold is not None:
            handles.append(ax.axhline(threshold, color="black", linestyle="--", linewidth=1, label=f"solved ({threshold:g})"))
        ax.legend(handles=handles, fontsize=7)
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x / 1e3:g}k" if x < 1e6 else f"{x / 1e6:g}M"))
        ax.set(title=env_id, xlabel="environment steps", ylabel="evaluation return")
        ax.grid(alpha=0.3)
    separator = "; " if n_columns > 2 else "\n"  # one line where it fits
    grid.figure.suptitle(
        f"IQM over seeds of the deterministic evaluation return{separator}band: its 95% bootstrap CI", fontsize=10
    )
    grid.figure.tight_layout()
    grid.figure.savefig(path, dpi=100)
    plt.close(grid.figure)
    return grid.figure
