"""
A comparison's folder: the one module that knows its layout, the name of every file in it, and what a run's
specification is. The command, the runner, the report and the tables read and write a comparison through it::

    OUT/comparison.json                  the environment and the solve threshold
    OUT/per_run/<algo>_seed<seed>.csv    a run's evaluations, a row appended after each
    OUT/per_run/<algo>_seed<seed>.train.jsonl
                                         a run's training diagnostics at each evaluation (the logger's last train/*
                                         values, the training episodes' mean return and length), a line appended each
    OUT/per_run/<algo>_seed<seed>.json   a finished run's summary: its presence marks the run finished
    OUT/per_run/<algo>_seed<seed>.checkpoint.zip, .checkpoint_vecnormalize.pkl, .checkpoint.json
                                         an unfinished run's last checkpoint (the JSON written last)
    OUT/results.csv, summary.csv, summary.md, learning_curve.png
                                         rebuilt from the finished runs

A run interrupted after its first evaluation past step 0 resumes from its checkpoint when run again with the same settings
(weights, optimizer, steps and schedules kept; running episodes lost, so its curve differs, see
``resumed_at_steps``).
"""

import csv
import io
import json
import os
import pickle
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from sb3_reinforce.lab.resource_use import process_tree_cpu_s
from sb3_reinforce.lab.stats import solve_threshold
from sb3_reinforce.safeguards import load_with_random_state, save_with_random_state

if TYPE_CHECKING:
    from sb3_reinforce.lab.compare.experiment import ZooEntry

__all__ = ["PER_RUN_DIR", "RESULT_COLUMNS", "Checkpoint", "ComparisonFolder", "RunSpec"]

#: Subfolder of a comparison's folder with each run's evaluations (CSV), summary (JSON) and checkpoint.
PER_RUN_DIR = "per_run"
#: Columns of a run's CSV and of ``results.csv``: one row per algorithm, seed and evaluation point.
RESULT_COLUMNS = [
    "env",
    "algo",
    "seed",
    "eval_index",
    "steps",
    "episodes",
    "wall_time_s",
    "mean_return",
    "std_return",
    "mean_return_stochastic",
    "std_return_stochastic",
    "peak_rss_mb",
]
#: ``VecNormalize``'s running statistics, saved with a checkpoint.
_RUNNING_STATISTICS = ("obs_rms", "ret_rms")


@dataclass(frozen=True)
class RunSpec:
    """
    Everything that defines one run (and the settings a resumed run must share).

    :param env_id: The environment id
    :param algo: An algorithm rl_zoo3 knows (``"reinforce"``, ``"ppo"``, ``"a2c"``, ``"trpo"``, ...)
    :param seed: The seed (model, training and evaluation environments)
    :param budget: Training environment steps
    :param eval_freq: Evaluate every this many environment steps
    :param n_eval_episodes: Episodes per evaluation (deterministic, and again stochastic)
    :param config_path: The zoo yml (None: :func:`~sb3_reinforce.lab.compare.experiment.read_entry`'s default)
    :param stop_at: End the run at its first deterministic evaluation at or above this return, before its budget
        (None: train the whole budget); recorded in the identity only when set
    :param entry: The algorithm's zoo entry as the command read it (None: not read); not part of the identity. The
        worker that trains the run reads the file again, as ``sb3-reinforce-zoo train`` does, to build the model
    """

    env_id: str
    algo: str
    seed: int
    budget: int
    eval_freq: int
    n_eval_episodes: int
    config_path: str | None = None
    stop_at: float | None = None
    entry: "ZooEntry | None" = field(default=None, compare=False, repr=False)

    @property
    def name(self) -> str:
        """File stem of this run's outputs."""
        return f"{self.algo}_seed{self.seed}"

    def identity(self) -> dict[str, Any]:
        """The settings that define the run, as its summary and checkpoint record them."""
        identity = {f.name: getattr(self, f.name) for f in fields(self) if f.compare}
        if self.stop_at is None:  # as the runs made before it existed recorded themselves
            del identity["stop_at"]
        return identity


def write_replacing(path: Path, data: bytes) -> None:
    """Write ``path`` whole, then rename it into place: an interruption leaves the old file or the new one."""
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)


class Checkpoint:
    """
    A run's checkpoint: the model (with its random generators), ``VecNormalize``'s statistics and the state (JSON),
    each written whole then renamed, the JSON last: without it the checkpoint is ignored.

    :param paths: The model's, the statistics' and the state's files (:meth:`ComparisonFolder.checkpoint`)
    :param spec: The run
    :param hyperparams: The run's zoo entry as in its summary (a checkpoint made with other values is not resumed)
    :param vec_env: The kind of training environments of this process (``"dummy"``, ``"subproc"`` or ``"envpool"``)
    :param cpu_at_start: :func:`process_tree_cpu_s` when the run started in this process (counted from there)
    :param device: Where the model computes in this process (PyTorch's device name, as given)
    :param system: This process's :func:`~sb3_reinforce.lab.provenance.system_info` (None: not recorded)
    """

    def __init__(
        self,
        paths: tuple[Path, Path, Path],
        spec: RunSpec,
        hyperparams: dict[str, str],
        vec_env: str = "dummy",
        cpu_at_start: float = 0.0,
        device: str = "cpu",
        system: dict[str, str] | None = None,
    ) -> None:
        self.model_path, self.vecnormalize_path, self.state_path = paths
        self.cpu_at_start = cpu_at_start
        self.spec = spec
        self.hyperparams = hyperparams
        self.vec_envs = [vec_env]
        self.devices = [device]
        self.systems = [system]
        self.cpu_time_before = 0.0
        self.resumed_at_steps: list[int] = []

    def save(self, model: BaseAlgorithm, counters: dict[str, Any]) -> None:
        """Save the model and the counters (the JSON is removed first and written last)."""
        self.state_path.parent.mkdir(parents=True, exist_ok=True)
        self.state_path.unlink(missing_ok=True)
        temporary_model = self.model_path.with_suffix(".tmp.zip")
        save_with_random_state(model, temporary_model)  # a resumed run draws what an uninterrupted one draws
        os.replace(temporary_model, self.model_path)
        vecnormalize = model.get_vec_normalize_env()
        if vecnormalize is not None:
            # obs_rms exists only with norm_obs=True
            statistics = {name: vecnormalize.__dict__[name] for name in _RUNNING_STATISTICS if name in vecnormalize.__dict__}
            write_replacing(self.vecnormalize_path, pickle.dumps(statistics))
        state = dict(
            spec=self.spec.identity(),
            hyperparams=self.hyperparams,
            counters=counters,
            cpu_time_s=self.cpu_time_s(),
            resumed_at_steps=self.resumed_at_steps,
            vec_envs=self.vec_envs,
            devices=self.devices,
            systems=self.systems,
        )
        write_replacing(self.state_path, json.dumps(state, indent=2).encode())

    def cpu_time_s(self) -> float:
        """CPU seconds of the run so far, in this process (environment processes included) and those it resumes."""
        return self.cpu_time_before + process_tree_cpu_s() - self.cpu_at_start

    def exists(self) -> bool:
        """Whether a complete checkpoint (the model and, written last, the JSON) is there, of whichever settings."""
        return self.state_path.exists() and self.model_path.exists()

    def load_state(self) -> dict[str, Any] | None:
        """The saved state, or None without a complete checkpoint of this very run (other settings, or a damaged file)."""
        if not self.exists():
            return None
        try:
            state = json.loads(self.state_path.read_text())
        except json.JSONDecodeError:
            return None
        # Older checkpoints without hyperparameters match them
        same_run = state.get("spec") == self.spec.identity() and state.get("hyperparams", self.hyperparams) == self.hyperparams
        return state if same_run else None

    def restore(self, model: BaseAlgorithm, state: dict[str, Any]) -> BaseAlgorithm:
        """
        The model of the checkpoint, on ``model``'s training env with its ``VecNormalize`` statistics restored.

        :param model: The freshly built model of the run (its env is reused)
        :param state: :meth:`load_state`'s result
        :return: The restored model
        """
        env = model.get_env()
        restored = load_with_random_state(type(model), self.model_path, env=env, device=model.device)
        vecnormalize = restored.get_vec_normalize_env()
        if vecnormalize is not None:
            with self.vecnormalize_path.open("rb") as f:
                statistics = pickle.load(f)  # written by this run (on a worker of its cluster), see save()
            vecnormalize.__dict__.update(statistics)
        self.cpu_time_before = float(state["cpu_time_s"])
        self.resumed_at_steps = [*state["resumed_at_steps"], int(restored.num_timesteps)]
        # Older checkpoints without the kind all used DummyVecEnv
        earlier = state.get("vec_envs", ["dummy"] * (1 + len(state["resumed_at_steps"])))
        self.vec_envs = [*earlier, self.vec_envs[-1]]
        # Older checkpoints without the device all trained on the CPU
        self.devices = [*state.get("devices", ["cpu"] * len(earlier)), self.devices[-1]]
        # Older checkpoints did not record the system of their parts
        self.systems = [*state.get("systems", [None] * len(earlier)), self.systems[-1]]
        return restored

    def delete(self) -> None:
        """Remove the checkpoint's files (the run is finished)."""
        for path in (self.state_path, self.model_path, self.vecnormalize_path):
            path.unlink(missing_ok=True)


class ComparisonFolder:
    """
    A comparison's folder on disk (see the module docstring for its layout).

    :param root: The folder (``--out``); it need not exist yet
    """

    RESULTS = "results.csv"
    SUMMARY_CSV = "summary.csv"
    SUMMARY_MD = "summary.md"
    LEARNING_CURVE = "learning_curve.png"
    META = "comparison.json"

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.runs_dir = self.root / PER_RUN_DIR

    @staticmethod
    def holds_comparison(root: Path) -> bool:
        """Whether ``root`` is a comparison's folder (it has ``per_run/``)."""
        return (Path(root) / PER_RUN_DIR).is_dir()

    # -- the comparison ---------------------------------------------------------------------------------------------
    def write_meta(self, env_id: str, threshold: float | None) -> None:
        """Record the environment and the solve threshold."""
        self.root.mkdir(parents=True, exist_ok=True)
        (self.root / self.META).write_text(json.dumps(dict(env=env_id, threshold=threshold), indent=2))

    def read_meta(self) -> tuple[str, float | None]:
        """The environment and the threshold (a folder without ``comparison.json``: a run's env, its known threshold)."""
        path = self.root / self.META
        if path.exists():
            meta = json.loads(path.read_text())
            return meta["env"], meta["threshold"]
        summary = next(iter(self.load_summaries().values()), None)
        if summary is None:
            raise ValueError(f"{self.root} has no finished run yet")
        env_id = summary["spec"]["env_id"]
        return env_id, solve_threshold(env_id)

    def results(self) -> pd.DataFrame:
        """The rebuilt ``results.csv`` (every finished run's evaluations)."""
        path = self.output(self.RESULTS)
        if not path.exists():
            raise ValueError(f"{self.root} has no {self.RESULTS}: no finished run yet (or not a comparison folder)")
        return pd.read_csv(path)

    def output(self, name: str) -> Path:
        """The path of one of the rebuilt files (:attr:`RESULTS`, :attr:`SUMMARY_MD`, ...)."""
        return self.root / name

    # -- runs -------------------------------------------------------------------------------------------------------
    def evaluations_path(self, spec: RunSpec) -> Path:
        """A run's CSV of evaluations."""
        return self.runs_dir / f"{spec.name}.csv"

    def training_log_path(self, spec: RunSpec) -> Path:
        """A run's training diagnostics, one JSON line per evaluation."""
        return self.runs_dir / f"{spec.name}.train.jsonl"

    def summary_path(self, spec: RunSpec) -> Path:
        """A finished run's summary."""
        return self.runs_dir / f"{spec.name}.json"

    def checkpoint(
        self,
        spec: RunSpec,
        hyperparams: dict[str, str],
        vec_env: str = "dummy",
        cpu_at_start: float = 0.0,
        device: str = "cpu",
        system: dict[str, str] | None = None,
    ) -> Checkpoint:
        """A run's :class:`Checkpoint` in ``per_run/`` (see :class:`Checkpoint` for the arguments)."""
        paths = (
            self.runs_dir / f"{spec.name}.checkpoint.zip",
            self.runs_dir / f"{spec.name}.checkpoint_vecnormalize.pkl",
            self.runs_dir / f"{spec.name}.checkpoint.json",
        )
        return Checkpoint(paths, spec, hyperparams, vec_env, cpu_at_start, device, system)

    def resume(
        self,
        spec: RunSpec,
        model: BaseAlgorithm,
        hyperparams: dict[str, str],
        vec_env: str,
        cpu_at_start: float,
        device: str,
        system: dict[str, str],
    ) -> tuple[BaseAlgorithm, Checkpoint | None, dict[str, Any] | None]:
        """
        Where a run goes on from: its checkpoint (None for an off-policy run: ``model.save`` leaves the replay buffer
        out), and if the checkpoint is of these very settings, the model restored from it and its counters. The run's
        CSV is started, or cut back to the checkpoint's evaluations.

        :param model: The freshly built model of the run
        :return: The model to train (restored or ``model``), the checkpoint, and the counters resumed (None: from scratch)
        """
        if isinstance(model, OffPolicyAlgorithm):
            self.start_evaluations(spec, None)
            return model, None, None
        checkpoint = self.checkpoint(spec, hyperparams, vec_env, cpu_at_start, device, system)
        state = checkpoint.load_state() if self.evaluations_path(spec).exists() else None
        resumed = None
        if state is not None:
            model = checkpoint.restore(model, state)
            resumed = state["counters"]
        self.start_evaluations(spec, None if resumed is None else int(resumed["eval_index"]))
        return model, checkpoint, resumed

    def start_evaluations(self, spec: RunSpec, resumed_eval_index: int | None) -> None:
        """
        Start a run's CSV with its header and an empty training log, or, for a run resuming at
        ``resumed_eval_index``, drop from both the evaluations made after its checkpoint.
        """
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        path = self.evaluations_path(spec)
        kept = [RESULT_COLUMNS]
        if resumed_eval_index is not None:
            with path.open(newline="") as f:
                rows = list(csv.reader(f))
            column = RESULT_COLUMNS.index("eval_index")
            kept = [rows[0]] + [row for row in rows[1:] if int(row[column]) < resumed_eval_index]
        buffer = io.StringIO()
        csv.writer(buffer).writerows(kept)
        write_replacing(path, buffer.getvalue().encode())
        log = self.training_log_path(spec)
        lines = log.read_text().splitlines() if resumed_eval_index is not None and log.exists() else []
        kept_lines = [line + "\n" for line in lines if json.loads(line)["eval_index"] < (resumed_eval_index or 0)]
        write_replacing(log, "".join(kept_lines).encode())

    def append_evaluation(self, spec: RunSpec, row: list[Any]) -> None:
        """Append one evaluation (the values of :data:`RESULT_COLUMNS`) to a run's CSV."""
        with self.evaluations_path(spec).open("a", newline="") as f:
            csv.writer(f).writerow(row)

    def append_training_log(self, spec: RunSpec, record: dict[str, Any]) -> None:
        """Append one evaluation's training diagnostics (``eval_index``, ``steps``, then any numbers) to the run's log."""
        with self.training_log_path(spec).open("a") as f:
            f.write(json.dumps(record) + "\n")

    def write_summary(self, spec: RunSpec, summary: dict[str, Any]) -> None:
        """Write a finished run's summary (the mark that it is finished)."""
        write_replacing(self.summary_path(spec), json.dumps(summary, indent=2).encode())

    def _summary_files(self) -> list[Path]:
        """The finished runs' summaries (an unfinished run's ``.checkpoint.json`` is not one)."""
        return [path for path in sorted(self.runs_dir.glob("*.json")) if not path.name.endswith(".checkpoint.json")]

    def load_summaries(self) -> dict[tuple[str, int], dict[str, Any]]:
        """The finished runs' summaries: ``{(algo, seed): summary}``."""
        summaries = {}
        for path in self._summary_files():
            summary = json.loads(path.read_text())
            summaries[(summary["spec"]["algo"], int(summary["spec"]["seed"]))] = summary
        return summaries

    def finished_evaluations(self) -> pd.DataFrame | None:
        """The evaluations of the finished runs, one frame (None: no run has finished)."""
        paths = [path.with_suffix(".csv") for path in self._summary_files()]  # a run's CSV beside its summary
        return pd.concat([pd.read_csv(path) for path in paths], ignore_index=True) if paths else None

    def runs_to_do(self, specs: list[RunSpec]) -> list[RunSpec]:
        """The runs still to do; refuse a folder whose finished runs used other settings."""
        todo = []
        for spec in specs:
            path = self.summary_path(spec)
            if not path.exists():
                todo.append(spec)
                continue
            done = json.loads(path.read_text())["spec"]
            if done != spec.identity():
                raise ValueError(
                    f"{path} is a finished run with other settings ({done}): use another --out, or the same settings"
                )
        return todo

    # -- a run's files, shipped to and from the machine that trains it ----------------------------------------------
    def run_files_pattern(self, spec: RunSpec) -> str:
        """The glob, relative to the folder, of a run's files."""
        return f"{PER_RUN_DIR}/{spec.name}.*"

    def run_files(self, spec: RunSpec) -> dict[str, bytes]:
        """The files of an unfinished run (its CSV and checkpoint), relative paths to bytes, to resume it anywhere."""
        return {
            path.relative_to(self.root).as_posix(): path.read_bytes()
            for path in sorted(self.root.glob(self.run_files_pattern(spec)))
            if ".tmp" not in path.name
        }

    def write_run_files(self, files: dict[str, bytes]) -> None:
        """Write a run's files (relative paths) atomically; the JSON files (completion marks) go last."""
        for relative in files:
            if Path(relative).is_absolute() or ".." in Path(relative).parts:
                raise ValueError(f"a run sent back a file outside its folder: {relative!r}")
            if relative.endswith(".json"):
                (self.root / relative).unlink(missing_ok=True)
        for relative, data in sorted(files.items(), key=lambda item: item[0].endswith(".json")):
            (self.root / relative).parent.mkdir(parents=True, exist_ok=True)
            write_replacing(self.root / relative, data)

    def write_finished_run(self, spec: RunSpec, files: dict[str, bytes], worker: str) -> None:
        """Write a finished run's files, its summary marked with the ``worker`` that ran it, and remove the rest."""
        summary_name = self.summary_path(spec).relative_to(self.root).as_posix()
        summary = dict(json.loads(files[summary_name]), worker=worker)
        self.write_run_files(files | {summary_name: json.dumps(summary, indent=2).encode()})
        for path in self.root.glob(self.run_files_pattern(spec)):  # its checkpoint, deleted at its end
            if path.relative_to(self.root).as_posix() not in files:
                path.unlink()
