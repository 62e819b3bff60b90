"""
rl-baselines3-zoo integration: ``python -m sb3_reinforce.lab.zoo`` (train, enjoy, benchmark, record-video,
--optimize, distributed studies), the shipped zoo_configs, and the errors bad input gives.
"""

import contextlib
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import optuna
import pytest
import rl_zoo3.exp_manager
import sqlalchemy
import yaml
from gymnasium.envs.classic_control import CartPoleEnv
from stable_baselines3 import A2C, PPO, TD3
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.seed.presets import seed_hyperparams
from sb3_reinforce.lab.zoo import config_path, main
from sb3_reinforce.lab.zoo.hyperparams_opt import (
    NORMALIZE_OBSERVATIONS,
    convert_reinforce_params,
    parse_zoo_entry,
    sample_reinforce_params,
    suggest_n_envs,
    suggest_normalize_observations,
)
from sb3_reinforce.lab.zoo.storage import owes_retry

if sys.version_info >= (3, 11):
    import tomllib
else:  # pytest depends on tomli before Python 3.11
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
CONFIGS = {name: REPO / "zoo_configs" / f"{name}.yml" for name in ("reinforce", "reinforce_seed")}
#: rl_zoo3's fallback entries, for an env without one of its own (not an env id)
FALLBACK_ENTRIES = ("default", "atari")
ENTRIES = [
    (name, env_id)
    for name, path in CONFIGS.items()
    for env_id in yaml.safe_load(path.read_text())
    if env_id not in FALLBACK_ENTRIES
]
REQUIRED_ENVS = {
    "CartPole-v1",
    "Acrobot-v1",
    "LunarLander-v3",
    "MountainCar-v0",
    "Pendulum-v1",
    "LunarLanderContinuous-v3",
    "CarRacing-v3",
}


def run_zoo(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``python -m sb3_reinforce.lab.zoo ARGS`` in a fresh interpreter (the real command line)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]), CUDA_VISIBLE_DEVICES="")
    return subprocess.run(
        [sys.executable, "-m", "sb3_reinforce.lab.zoo", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def load_saved_config(run_dir: Path, env_id: str) -> dict[str, Any]:
    """The hyperparameters the zoo saved with a run (``<run>/<env>/config.yml``)."""
    return dict(yaml.load((run_dir / env_id / "config.yml").read_text(), Loader=yaml.UnsafeLoader))


def zoo_eval(expression: str) -> Any:
    """Evaluate a config string (``policy_kwargs``) with the names the zoo has in scope when it does."""
    return eval(expression, vars(rl_zoo3.exp_manager))


def test_default_config_is_ours() -> None:
    assert config_path("reinforce") == CONFIGS["reinforce"]
    assert config_path("reinforce_seed") == CONFIGS["reinforce_seed"]
    assert REQUIRED_ENVS <= set(yaml.safe_load(CONFIGS["reinforce"].read_text()))
    with pytest.raises(ValueError, match="`name` must be one of"):
        config_path("ppo")


def test_configs_ship_in_the_installed_package(tmp_path: Path) -> None:
    # Lay the package out as pyproject.toml tells setuptools to (package-dir + package-data), outside the
    # checkout, and check that an installed copy finds its own config files.
    setuptools_conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    site = tmp_path / "site"
    for package in setuptools_conf["packages"]:
        source = REPO / setuptools_conf["package-dir"].get(package, package.replace(".", "/"))
        target = site / package.replace(".", "/")
        target.mkdir(parents=True, exist_ok=True)
        patterns = ["*.py", *setuptools_conf["package-data"].get(package, [])]
        for pattern in patterns:
            for file in source.glob(pattern):
                shutil.copy(file, target / file.name)
    # Load the copied shipped module by itself (it needs nothing else), so that __file__ is the copy's.
    spec = importlib.util.spec_from_file_location("installed_shipped", site / "sb3_reinforce/lab/zoo/shipped.py")
    assert spec is not None and spec.loader is not None
    installed = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(installed)
    paths = [installed.config_path("reinforce"), installed.config_path("reinforce_seed")]
    configs = (site / "sb3_reinforce/lab/zoo/configs").resolve()
    assert paths == [configs / "reinforce.yml", configs / "reinforce_seed.yml"]
    assert paths[0].read_text() == CONFIGS["reinforce"].read_text()


def test_every_package_is_listed_in_pyproject() -> None:
    # pyproject.toml lists the packages explicitly (to map zoo_configs/ into the package): a new subpackage
    # must be added there, or wheels would silently leave it out.
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(init.parent.relative_to(REPO).parts) for init in (REPO / "sb3_reinforce").rglob("__init__.py")}
    assert found <= listed


def test_train_enjoy_benchmark_record_video(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Train through the real entry point with our default config.
    out = run_zoo(
        "train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "2000", "--seed", "0", "--num-threads", "1",
        "--eval-freq", "1000", "--eval-episodes", "2", "-f", "logs",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-3000:]
    run_dir = tmp_path / "logs" / "reinforce" / "CartPole-v1_1"
    assert f"Loading hyperparameters from: {CONFIGS['reinforce']}" in out.stdout
    expected = yaml.safe_load(CONFIGS["reinforce"].read_text())["CartPole-v1"]
    assert load_saved_config(run_dir, "CartPole-v1") == expected
    model = REINFORCE.load(run_dir / "CartPole-v1.zip", device="cpu")
    assert isinstance(model, REINFORCE)
    assert model.num_timesteps >= 2000
    assert (run_dir / "best_model.zip").is_file()

    monkeypatch.chdir(tmp_path)
    # enjoy loads the REINFORCE model and plays it, headless
    assert main(["enjoy", "--algo", "reinforce", "--env", "CartPole-v1", "-f", "logs", "--no-render", "-n", "600"]) == 0
    # benchmark evaluates every trained agent of the folder (through `enjoy`, in a subprocess)
    args = ["--log-dir", "logs", "--benchmark-dir", "bench", "--no-hub", "--test-mode", "-n", "600", "--num-threads", "1"]
    assert main(["benchmark", *args]) == 0
    table = (tmp_path / "bench" / "benchmark.md").read_text()
    assert "|reinforce|CartPole-v1|" in table.replace(" ", "")
    # record-video
    args = ["--algo", "reinforce", "--env", "CartPole-v1", "-f", "logs", "-n", "50", "-o", "videos"]
    assert main(["record-video", *args]) == 0
    assert list((tmp_path / "videos").glob("*reinforce-CartPole-v1*.mp4"))


@pytest.mark.parametrize("flag, threads", [([], 1), (["--num-threads", "2"], 2), (["--num-threads=3"], 3)])
def test_train_runs_torch_on_one_thread_unless_told(
    flag: list[str], threads: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Issue 62: torch's default threads made learn ~5x slower on a shared 2-core machine (torch_threads.csv)
    import torch as th

    before = th.get_num_threads()
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "100", "--eval-freq", "-1", "--verbose", "2"]
    assert main([*args, *flag, "-f", str(tmp_path)]) == 0
    assert f"Setting torch.num_threads to {threads}\n" in capsys.readouterr().out  # rl_zoo3's own line
    assert th.get_num_threads() == before  # the caller's process keeps its count


def test_benchmark_table_stays_in_the_benchmark_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # Without --test-mode, rl_zoo3's benchmark also copies its table to ./benchmark.md (the zoo clone's own
    # README table): here the table is written to --benchmark-dir only. A trained agent whose evaluation is
    # already logged (the benchmark then skips `enjoy`): the saved args and config, and the evaluation's monitor file.
    monkeypatch.chdir(tmp_path)
    saved = tmp_path / "logs" / "reinforce" / "CartPole-v1_1" / "CartPole-v1"
    saved.mkdir(parents=True)
    (saved / "args.yml").write_text(yaml.dump({"env": "CartPole-v1", "algo": "reinforce"}))
    (saved / "config.yml").write_text(yaml.dump({"n_timesteps": 100_000, "policy": "MlpPolicy"}))
    evaluation = tmp_path / "bench" / "reinforce-CartPole-v1"
    evaluation.mkdir(parents=True)
    monitor = '#{"t_start": 0.0, "env_id": "CartPole-v1"}\nr,l,t\n500.0,500,1.0\n480.0,480,2.0\n'
    (evaluation / "0.monitor.csv").write_text(monitor)
    assert main(["benchmark", "--log-dir", "logs", "--benchmark-dir", "bench", "--no-hub", "--num-threads", "1"]) == 0
    assert not (tmp_path / "benchmark.md").exists()
    assert "|reinforce|CartPole-v1|490|" in (tmp_path / "bench" / "benchmark.md").read_text().replace(" ", "")
    printed = capsys.readouterr().out
    assert f"Results written to: {os.path.join('bench', 'benchmark.md')}" in printed and "copied" not in printed
    # shutil.copy is rl_zoo3's own again afterwards
    shutil.copy(tmp_path / "bench" / "benchmark.md", "benchmark.md")
    assert (tmp_path / "benchmark.md").exists()


@pytest.mark.parametrize(
    "algo, algo_class, env_id", [("a2c", A2C, "CartPole-v1"), ("ppo", PPO, "CartPole-v1"), ("td3", TD3, "Pendulum-v1")]
)
def test_zoo_algorithms_still_work(tmp_path: Path, algo: str, algo_class: type, env_id: str) -> None:
    args = ["train", "--algo", algo, "--env", env_id, "-n", "300", "--eval-freq", "-1", "--seed", "0"]
    assert main([*args, "-f", str(tmp_path), "--verbose", "0"]) == 0
    run_dir = tmp_path / algo / f"{env_id}_1"
    # the zoo's own hyperparameters for that algorithm, not ours
    zoo_config = Path(rl_zoo3.exp_manager.__file__).parent / "hyperparams" / f"{algo}.yml"
    assert load_saved_config(run_dir, env_id) == yaml.safe_load(zoo_config.read_text())[env_id]
    assert isinstance(algo_class.load(run_dir / f"{env_id}.zip", device="cpu"), algo_class)


@pytest.mark.parametrize("config, env_id", ENTRIES)
def test_config_entry_builds_and_trains(tmp_path: Path, config: str, env_id: str) -> None:
    # Parse + construct + a few hundred steps (episodes cut at 50 steps to keep it short) + save/load.
    entry = yaml.safe_load(CONFIGS[config].read_text())[env_id]
    args = ["train", "--algo", "reinforce", "-conf", str(CONFIGS[config]), "--env", env_id, "-n", "200", "--seed", "0"]
    args += ["--eval-freq", "-1", "-f", str(tmp_path), "--verbose", "0", "--env-kwargs", "max_episode_steps:50"]
    assert main(args) == 0
    model = REINFORCE.load(tmp_path / "reinforce" / f"{env_id}_1" / f"{env_id}.zip", device="cpu")
    assert model.num_timesteps >= 200
    assert model.n_envs == entry.get("n_envs", 1)
    assert type(model.policy) is REINFORCE.policy_aliases[entry["policy"]]
    for key in ("n_episodes", "min_steps", "gamma", "baseline", "normalize_returns", "ent_coef", "max_grad_norm"):
        if key in entry:
            assert getattr(model, key) == entry[key], key
    learning_rate = entry.get("learning_rate", 1e-3)
    if isinstance(learning_rate, str):  # rl_zoo3's "lin_<x>": from x at the start to 0 at the end of the budget
        assert learning_rate.startswith("lin_"), learning_rate
        learning_rate = float(learning_rate[len("lin_") :])
        assert model.lr_schedule(0.25) == pytest.approx(0.25 * learning_rate)
    assert model.lr_schedule(1.0) == pytest.approx(learning_rate)
    if "policy_kwargs" in entry:
        policy_kwargs = zoo_eval(entry["policy_kwargs"])
        assert {k: model.policy_kwargs[k] for k in policy_kwargs} == policy_kwargs


#: The verified configuration behind each zoo entry (benchmarks/configs/, run by ``sb3-reinforce compare`` on seeds
#: 1000-1009, LunarLander-v3's on 1030-1039, Acrobot-v1's on 1010-1019; CarRacing-v3's is its pilot's, on tuning seeds
#: 100-101 only): the entry must be that file's, key for key, or its results say nothing about it.
VERIFIED_CONFIGS = {
    "CarRacing-v3": "carracing_pilot/b_value20.yml",
    "Acrobot-v1": "acrobot_speed2/e4_loo.yml",
    "LunarLander-v3": "lunarlander_speed2/e4_ent001.yml",
    "LunarLanderContinuous-v3": "reinforce_llc_value20.yml",
    "Pendulum-v1": "reinforce_pendulum_gsde.yml",
    "MountainCar-v0": "reinforce_mountaincar_value20.yml",
}


@pytest.mark.parametrize("env_id", sorted(VERIFIED_CONFIGS))
def test_zoo_entry_is_the_verified_config(env_id: str) -> None:
    verified = REPO / "benchmarks" / "configs" / VERIFIED_CONFIGS[env_id]
    entry = yaml.load(CONFIGS["reinforce"].read_text(), Loader=yaml.UnsafeLoader)[env_id]
    assert entry == yaml.load(verified.read_text(), Loader=yaml.UnsafeLoader)[env_id]
    assert f"benchmarks/configs/{VERIFIED_CONFIGS[env_id]}" in CONFIGS["reinforce"].read_text()


@pytest.mark.parametrize("env_id", sorted(yaml.safe_load(CONFIGS["reinforce_seed"].read_text())))
def test_seed_config_is_the_seed_preset(env_id: str) -> None:
    entry = yaml.safe_load(CONFIGS["reinforce_seed"].read_text())[env_id]
    as_constructor_args = {k: v for k, v in entry.items() if k not in ("n_envs", "n_timesteps", "env_kwargs", "env_wrapper")}
    as_constructor_args["policy_kwargs"] = zoo_eval(as_constructor_args["policy_kwargs"])
    as_constructor_args.pop("max_rollout_steps", None)
    assert entry["n_envs"] == 1
    assert as_constructor_args == seed_hyperparams(env_id)


def test_seed_mountaincar_has_no_time_limit() -> None:
    env_kwargs = yaml.safe_load(CONFIGS["reinforce_seed"].read_text())["MountainCar-v0"]["env_kwargs"]
    env = gym.make("MountainCar-v0", **env_kwargs)
    layer = env
    while isinstance(layer, gym.Wrapper):
        assert not isinstance(layer, gym.wrappers.TimeLimit)
        layer = layer.env
    # with the time limit removed, a constant action runs past the usual 200 steps
    env.reset(seed=0)
    for _ in range(300):
        _, _, terminated, truncated, _ = env.step(1)
        assert not (terminated or truncated)


def test_sampler_gives_valid_reinforce_arguments() -> None:
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    baselines, normalizations = set(), set()
    for _ in range(30):
        trial = study.ask()
        n_envs = suggest_n_envs(trial)
        normalize = suggest_normalize_observations(trial)  # as the experiment manager does, before the sampler
        try:
            kwargs = sample_reinforce_params(trial, 0, n_envs, {})
        except optuna.TrialPruned:
            # only a leave-one-out baseline with one episode per batch is pruned
            assert trial.params["baseline"] == "loo" and trial.params["n_envs"] * trial.params["n_episodes"] == 1
            study.tell(trial, state=optuna.trial.TrialState.PRUNED)
            continue
        assert "n_envs" not in kwargs and "normalize" not in kwargs  # they set the env, not the model
        baselines.add(trial.params["baseline"])
        normalizations.add(normalize)
        model = REINFORCE("MlpPolicy", make_vec_env("CartPole-v1", n_envs=n_envs), device="cpu", **kwargs)
        assert model.n_envs == n_envs
        assert model.n_value_steps == trial.params.get("n_value_steps", 0)
        # what the zoo's --trial-id loading does with the stored params: a zoo entry, parsed as the zoo parses files
        entry = convert_reinforce_params(trial.params)
        assert entry["n_envs"] == n_envs and yaml.safe_load(yaml.safe_dump(entry)) == entry  # plain YAML values
        assert entry.get("normalize") == (NORMALIZE_OBSERVATIONS if normalize else None)
        parsed = parse_zoo_entry(entry)
        zoo_keys = ("n_envs", "normalize", "policy_kwargs")
        assert {k: v for k, v in parsed.items() if not callable(v) and k not in zoo_keys} == {
            k: v for k, v in kwargs.items() if not callable(v) and k != "policy_kwargs"
        }
        assert parsed["policy_kwargs"] == kwargs["policy_kwargs"]
        for progress in (1.0, 0.5):
            assert parsed["learning_rate"](progress) == kwargs["learning_rate"](progress)
        assert kwargs["learning_rate"](0.5) == trial.params["learning_rate"] * (
            0.5 if trial.params["lr_schedule"] == "linear" else 1.0
        )
        study.tell(trial, 0.0)
    assert baselines == {"none", "value", "loo"} and normalizations == {False, True}
    trial = study.ask()
    trial.suggest_categorical("n_envs", [1, 2, 4, 8])
    with pytest.raises(RuntimeError, match=r"sb3_reinforce\.lab\.zoo"):
        sample_reinforce_params(trial, 0, trial.params["n_envs"] * 3, {})


def test_trials_of_older_studies_still_convert() -> None:
    # trials stored before lr_schedule and n_value_steps were searched: a constant rate and the joint value step
    old = dict(learning_rate=1e-3, one_minus_gamma=0.01, n_episodes=2, net_arch="small", activation_fn="tanh")
    old.update(baseline="value", ent_coef=1e-4, max_grad_norm=0.0, normalize_returns=True, n_envs=4)
    entry = convert_reinforce_params(old)
    assert entry["learning_rate"] == 1e-3 and "n_value_steps" not in entry and entry["max_grad_norm"] is None
    assert entry["policy_kwargs"] == "dict(net_arch=[64, 64], activation_fn=nn.Tanh)"


def test_optimize_two_trials(tmp_path: Path) -> None:
    storage = tmp_path / "study.log"
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "2", "-n", "1000"]
    args += ["--n-evaluations", "2", "--eval-episodes", "2", "--sampler", "random", "--seed", "0", "--no-optim-plots"]
    args += ["--storage", str(storage), "--study-name", "two-trials", "-f", str(tmp_path), "--verbose", "0"]
    assert main(args) == 0
    study = optuna.load_study(
        study_name="two-trials",
        storage=optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(storage))),
    )
    assert len(study.trials) == 2
    finished = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    assert all(trial.state in finished for trial in study.trials)
    assert all(set(trial.params) >= {"n_envs", "learning_rate", "baseline", "net_arch"} for trial in study.trials)
    assert list((tmp_path / "reinforce").glob("report_CartPole-v1_2-trials-1000-random-median_*.csv"))

    # Train with the hyperparameters of a trial (the zoo's --trial-id; trial 0 too, which rl_zoo3 alone skips)
    for number in (0, 1):
        args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "200", "--eval-freq", "-1", "--verbose", "0"]
        args += ["--storage", str(storage), "--study-name", "two-trials", "--trial-id", str(number)]
        assert main([*args, "-f", str(tmp_path / f"trial{number}")]) == 0
        path = tmp_path / f"trial{number}" / "reinforce" / "CartPole-v1_1" / "CartPole-v1.zip"
        model = REINFORCE.load(path, device="cpu")
        trial = parse_zoo_entry(convert_reinforce_params(study.trials[number].params))
        assert model.n_envs == trial["n_envs"]
        assert (model.n_episodes, model.baseline, model.gamma) == (trial["n_episodes"], trial["baseline"], trial["gamma"])
        assert model.policy_kwargs["net_arch"] == trial["policy_kwargs"]["net_arch"]


def test_optimize_applies_observation_normalization(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Each trial's training env is normalized (observations only) exactly when the trial sampled it; a config
    # with a `normalize` of its own is not searched over, and its normalization is every trial's.
    built: list[tuple[int, dict[str, bool] | None]] = []  # per training env: n_envs, VecNormalize's flags or None
    create_envs = rl_zoo3.exp_manager.ExperimentManager.create_envs

    def recording_create_envs(self: Any, n_envs: int, eval_env: bool = False, no_log: bool = False) -> VecEnv:
        env = create_envs(self, n_envs, eval_env=eval_env, no_log=no_log)
        if not eval_env:
            flags = {"obs": env.norm_obs, "reward": env.norm_reward} if isinstance(env, VecNormalize) else None
            built.append((n_envs, flags))
        return env

    monkeypatch.setattr(rl_zoo3.exp_manager.ExperimentManager, "create_envs", recording_create_envs)
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "6", "-n", "600"]
    args += ["--n-evaluations", "1", "--eval-episodes", "1", "--sampler", "random", "--seed", "0", "--no-optim-plots"]
    args += ["--storage", str(tmp_path / "study.log"), "--study-name", "normalization", "-f", str(tmp_path), "--verbose", "0"]
    assert main(args) == 0
    storage = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(tmp_path / "study.log")))
    study = optuna.load_study(study_name="normalization", storage=storage)
    trained = [trial for trial in study.trials if trial.state == optuna.trial.TrialState.COMPLETE]
    assert built.pop(0) == (1, None)  # the zoo's setup env, from the config, before the trials
    assert len(built) == len(trained) == 6
    normalized = {"obs": True, "reward": False}
    assert built == [(t.params["n_envs"], normalized if t.params["normalize_observations"] else None) for t in trained]
    assert {flags is not None for _, flags in built} == {False, True}

    built.clear()
    config = write_config(tmp_path, {"normalize": "{'norm_obs': False, 'norm_reward': True}"})
    args[args.index("normalization")] = "config-normalization"
    assert main([*args, "-conf", config]) == 0
    study = optuna.load_study(study_name="config-normalization", storage=storage)
    assert all("normalize_observations" not in trial.params for trial in study.trials)
    built.pop(0)  # the setup env
    assert [flags for _, flags in built] == [{"obs": False, "reward": True}] * len(built) and len(built) == 6


def test_distributed_study_two_workers(tmp_path: Path) -> None:
    # Two workers (separate processes) share one Optuna storage, as workers on several machines share one
    # PostgreSQL server (SQLite goes through the same RDB storage as PostgreSQL); each runs one trial.
    # test_optimize_two_trials uses the other kind of storage, a journal file.
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "1", "-n", "1000"]
    args += ["--n-evaluations", "1", "--eval-episodes", "2", "--sampler", "random", "--no-optim-plots"]
    args += ["--storage", storage, "--study-name", "shared", "--num-threads", "1"]
    # Create the study first, as the README says (workers setting up an empty database at once can collide)
    optuna.create_study(study_name="shared", storage=storage, direction="maximize")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]), CUDA_VISIBLE_DEVICES="")
    workers = [
        subprocess.Popen(
            [sys.executable, "-m", "sb3_reinforce.lab.zoo", *args, "--seed", str(seed), "-f", f"logs{seed}"],
            cwd=tmp_path,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for seed in (1, 2)
    ]
    outputs = [worker.communicate(timeout=600)[0] for worker in workers]
    assert [worker.returncode for worker in workers] == [0, 0], outputs
    study = optuna.load_study(study_name="shared", storage=storage)
    finished = [trial for trial in study.trials if trial.state == optuna.trial.TrialState.COMPLETE]
    assert len(finished) == 2
    worker_pids = {int(trial.user_attrs["worker"].rsplit(":", 1)[1]) for trial in finished}
    assert worker_pids == {worker.pid for worker in workers}
    # As rl_zoo3 records a study: its command and the entry's default hyperparameters
    assert "sb3_reinforce.lab.zoo" in study.user_attrs["command"]
    assert study.user_attrs["policy"] == "MlpPolicy"


# ---- bad input: one clear line on stderr and exit status 2, no traceback ----


def write_config(tmp_path: Path, entry: dict[str, Any]) -> str:
    path = tmp_path / "bad.yml"
    path.write_text(yaml.safe_dump({"CartPole-v1": {"n_timesteps": 1000, "policy": "MlpPolicy", **entry}}))
    return str(path)


def train_args(tmp_path: Path, *extra: str) -> list[str]:
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "100", "--eval-freq", "-1"]
    return [*args, "-f", str(tmp_path), *extra]


def test_unknown_algo(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = train_args(tmp_path)
    args[args.index("reinforce")] = "reinforc"
    assert main(args) == 2
    assert "invalid choice: 'reinforc'" in capsys.readouterr().err


def test_unknown_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["trian", "--algo", "reinforce"]) == 2
    assert "unknown command 'trian'" in capsys.readouterr().err


@pytest.mark.parametrize(
    "entry, message",
    [
        ({"n_steps": 5}, "REINFORCE does not accept 'n_steps'"),
        ({"gae_lambda": 0.9, "batch_size": 64}, "REINFORCE does not accept 'batch_size', 'gae_lambda'"),
        ({"gamma": 1.5}, "`gamma` must be a finite number in [0.0, 1.0], got 1.5"),
        ({"baseline": "critic"}, "`baseline` must be one of (None, 'value', 'loo'), got 'critic'"),
        ({"seed": 3}, "'seed' cannot be set in a config"),
    ],
)
def test_bad_config(tmp_path: Path, capsys: pytest.CaptureFixture[str], entry: dict[str, Any], message: str) -> None:
    assert main(train_args(tmp_path, "-conf", write_config(tmp_path, entry))) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "bad.yml [CartPole-v1]" in err


def test_missing_env_id(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = train_args(tmp_path)
    args[args.index("CartPole-v1")] = "CartPol-v1"
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "--env: Unknown environment 'CartPol-v1': not in the Gymnasium registry. Did you mean CartPole-v1" in err
    assert main(["enjoy", "--algo", "reinforce", "--env", "NoSuchEnv-v0", "-f", str(tmp_path), "--no-render"]) == 2
    assert "--env: Unknown environment 'NoSuchEnv-v0': not in the Gymnasium registry" in capsys.readouterr().err


def test_env_without_config_entry(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # A file without an entry for the env, nor a default one, is refused; the shipped file's default entry trains an
    # env it has no entry for with REINFORCE's defaults (test_compare.py: a user's own env)
    config = tmp_path / "cartpole_only.yml"
    config.write_text(yaml.safe_dump({"CartPole-v1": {"n_timesteps": 100, "policy": "MlpPolicy"}}))
    args = train_args(tmp_path, "-conf", str(config))
    args[args.index("CartPole-v1")] = "FrozenLake-v1"
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{config} has no entry for FrozenLake-v1 (it has: CartPole-v1). Add one" in err
    assert "default" in yaml.safe_load(CONFIGS["reinforce"].read_text())
    assert main(train_args(tmp_path, "-conf", str(tmp_path / "missing.yml"))) == 2
    assert "missing.yml (-conf/--conf-file) does not exist" in capsys.readouterr().err


class AtariEnv(CartPoleEnv):
    """A CartPole that rl_zoo3 takes for an Atari env (``ExperimentManager.is_atari`` reads the entry point's name)."""


def test_atari_env_needs_the_atari_entry(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # rl_zoo3 reads an Atari env's "atari" entry, never "default": a file with only "default" was a KeyError traceback
    gym.register("AtariLikeCartPole-v0", entry_point=AtariEnv, max_episode_steps=100)
    try:
        config = tmp_path / "default_only.yml"
        config.write_text(yaml.safe_dump({"default": {"n_timesteps": 1000, "policy": "MlpPolicy"}}))
        args = ["train", "--algo", "reinforce", "--env", "AtariLikeCartPole-v0", "-n", "100", "--eval-freq", "-1"]
        assert main([*args, "-f", str(tmp_path), "-conf", str(config)]) == 2
        err = capsys.readouterr().err
        assert "has no entry for AtariLikeCartPole-v0 (it has: default), nor the 'atari' entry" in err
    finally:
        del gym.registry["AtariLikeCartPole-v0"]


def test_bad_input_from_the_command_line_has_no_traceback(tmp_path: Path) -> None:
    out = run_zoo(*train_args(tmp_path, "-conf", write_config(tmp_path, {"n_steps": 5})), cwd=tmp_path)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert out.stderr.strip().splitlines()[-1].startswith("sb3-reinforce-zoo train: error: ")


def test_a_trial_that_fails_by_its_own_error_records_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A database study retries the trials of dead workers, not a trial whose training raised (it would fail again)
    def broken_objective(self: Any, trial: optuna.Trial) -> float:
        raise RuntimeError("the training broke")

    monkeypatch.setattr(rl_zoo3.exp_manager.ExperimentManager, "objective", broken_objective)
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "1", "-n", "600"]
    args += ["--sampler", "random", "--no-optim-plots", "--storage", storage, "--study-name", "broken", "-f", str(tmp_path)]
    with pytest.raises(RuntimeError, match="the training broke"):
        main(args)
    (trial,) = optuna.load_study(study_name="broken", storage=storage).trials
    assert trial.state == optuna.trial.TrialState.FAIL
    assert trial.user_attrs["error"] == "RuntimeError: the training broke"


def test_a_trial_whose_objective_is_not_finite_records_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Optuna records a NaN objective FAIL without an exception: a failure of the trial's own, not to be retried
    monkeypatch.setattr(rl_zoo3.exp_manager.ExperimentManager, "objective", lambda self, trial: float("nan"))
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "1", "-n", "600"]
    args += ["--sampler", "random", "--no-optim-plots", "--storage", storage, "--study-name", "nan", "-f", str(tmp_path)]
    with contextlib.suppress(ValueError):  # rl_zoo3's report of a study without a finished trial
        main(args)
    (trial,) = optuna.load_study(study_name="nan", storage=storage).trials
    assert trial.state == optuna.trial.TrialState.FAIL
    assert trial.user_attrs["error"] == "the objective value is nan"
    assert not owes_retry(trial, [trial], max_retry=3)


@pytest.mark.parametrize(
    "sqlstate, collided",
    [("42P07", True), ("42710", True), ("42601", False), (None, False)],
    ids=["duplicate table", "duplicate object", "syntax error", "no code"],
)
def test_a_worker_that_lost_the_race_to_create_the_tables_tries_again(sqlstate: str | None, collided: bool) -> None:
    # PostgreSQL answers the loser of two workers creating the tables at once with "relation ... already exists"
    # (a ProgrammingError, measured in a fresh-clone CI run): that is a retry, any other error is the user's
    from sb3_reinforce.lab.zoo.storage import _created_by_another_worker

    original = type("DriverError", (Exception,), {"sqlstate": sqlstate})()
    error = sqlalchemy.exc.ProgrammingError("CREATE TABLE studies", {}, original)
    assert _created_by_another_worker(error) is collided


#: A file or folder of the repository that a config's comment cites.
CITED_PATH = re.compile(r"benchmarks/(?:results|configs)/[\w./-]*[\w/]")


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_cited_results_exist(name: str) -> None:
    # what an entry's comment cites as its evidence is in the repository (results are never renamed away)
    cited = set(CITED_PATH.findall(CONFIGS[name].read_text()))
    assert [path for path in sorted(cited) if not (REPO / path).exists()] == []


def entry_blocks() -> dict[str, str]:
    """Each entry of the default file by env id: its text, comment lines included."""
    blocks = re.split(r"^(?=\S[^\n]*:\n)", CONFIGS["reinforce"].read_text(), flags=re.MULTILINE)
    return {block.split(":", 1)[0]: block for block in blocks if re.match(r"\S[^\n]*:\n", block)}


@pytest.mark.parametrize("env_id", sorted(set(yaml.safe_load(CONFIGS["reinforce"].read_text())) - set(FALLBACK_ENTRIES)))
def test_entry_cites_its_verification(env_id: str) -> None:
    # each env's entry of the default file says what it measured on fresh seeds, with the folder of that verification
    # (the default entry is the constructor's defaults: issue 62's study measures them)
    block = entry_blocks()[env_id]
    assert re.search(r"benchmarks/results/verify_\w+/", block), block


def test_tuned_entries_are_their_candidates() -> None:
    # an entry picked by the MuJoCo tuning study holds exactly the candidate's hyperparameters for its env (the study's
    # config is the one source: a hand-copied entry that drifted from what was tuned and verified fails here)
    entries = yaml.safe_load(CONFIGS["reinforce"].read_text())
    picked = {}
    for env_id, block in entry_blocks().items():
        found = re.search(r"# Source: candidate (\w+) of the MuJoCo tuning study", block)
        if found:
            picked[env_id] = found.group(1)
    assert {"HalfCheetah-v4", "Hopper-v4", "Walker2d-v4"} <= set(picked)
    for env_id, candidate in picked.items():
        study = yaml.safe_load((REPO / "benchmarks" / "configs" / "mujoco_tuning" / f"{candidate}.yml").read_text())
        assert entries[env_id] == study[env_id], f"{env_id}: not candidate {candidate}'s hyperparameters"
