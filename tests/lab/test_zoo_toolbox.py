"""
The rest of rl-baselines3-zoo's toolbox through ``sb3-reinforce-zoo`` with ``--algo reinforce``: the plots
(``plot_train``, ``all_plots``, ``plot_from_file``), ``record_training``, ``-tb`` and ``--track``, the Hub's
``push_to_hub`` and ``load_from_hub`` (everything up to the network: only huggingface_hub's HTTP calls are
replaced, by a folder), and how ``-f rl-trained-agents`` finds the agents this package ships.
"""

import importlib
import json
import os
import pickle
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import pytest
import yaml
from huggingface_hub import HfApi
from huggingface_hub.errors import HfHubHTTPError, RemoteEntryNotFoundError

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.zoo import main
from sb3_reinforce.lab.zoo.shipped import TRAINED_AGENTS, agents_folder, shipped_envs, trained_agents_dirs

matplotlib.use("Agg")  # plot_train ends with plt.show()

REPO = Path(__file__).resolve().parents[2]
ENV_ID = "CartPole-v1"
SEEDS = (0, 1)


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two short REINFORCE runs in the zoo's layout, with evaluations, a best model and checkpoints."""
    folder = tmp_path_factory.mktemp("zoo") / "logs"
    for seed in SEEDS:
        args = ["train", "--algo", "reinforce", "--env", ENV_ID, "-n", "2000", "-f", str(folder), "--seed", str(seed)]
        assert main([*args, "--eval-freq", "1000", "--eval-episodes", "2", "--save-freq", "1000"]) == 0
    return folder


def test_toolbox_commands_are_listed(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    usage = capsys.readouterr().out
    for command in ("plot_train", "all_plots", "plot_from_file", "record_training", "push_to_hub", "load_from_hub"):
        assert command in usage.splitlines()[0]


def test_plot_train(logs: Path) -> None:
    assert main(["plot_train", "-a", "reinforce", "-e", ENV_ID, "-f", str(logs), "-w", "5"]) == 0
    lines = matplotlib.pyplot.figure("Training Episodic Reward").axes[0].get_lines()
    assert sorted(line.get_label() for line in lines) == [f"{ENV_ID}_{n}" for n in (1, 2)]


def test_all_plots_then_plot_from_file(logs: Path, tmp_path: Path) -> None:
    results = tmp_path / "results"
    args = ["all_plots", "-a", "reinforce", "-e", ENV_ID, "-f", str(logs), "-l", "ours", "--no-display", "-o", str(results)]
    assert main([*args, "-max", "2000"]) == 0
    with open(f"{results}.pkl", "rb") as file:
        post_processed = pickle.load(file)
    curve = post_processed[ENV_ID]["REINFORCE-ours"]
    assert list(curve["timesteps"]) == [1000, 2000] and len(curve["last_evals"]) == len(SEEDS)

    matplotlib.pyplot.close("all")  # all_plots drew into the figure plot_from_file draws into
    image = tmp_path / "plot"
    assert main(["plot_from_file", "-i", f"{results}.pkl", "-o", str(image), "--format", "png"]) == 0
    assert image.read_bytes().startswith(b"\x89PNG")
    lines = matplotlib.pyplot.figure(f"Results {ENV_ID}").axes[0].get_lines()
    assert [line.get_label() for line in lines] == ["REINFORCE-ours"]


def test_record_training(logs: Path) -> None:
    # each checkpoint, the final and the best model are recorded by `record-video` (in a subprocess that knows
    # REINFORCE), then joined by ffmpeg (imageio-ffmpeg's where the PATH has none)
    videos = logs.parent / "videos"
    args = ["record_training", "--algo", "reinforce", "--env", ENV_ID, "-f", str(logs), "--exp-id", "1", "-n", "50"]
    assert main([*args, "-o", str(videos), "--gif"]) == 0
    names = sorted(path.name for path in videos.iterdir())
    assert [name.split("-reinforce-")[0] for name in names if name.endswith("to-step-50.mp4")] == [
        "best-model",
        "checkpoint-1000",
        "checkpoint-2000",
        "final-model",
    ]
    assert (videos / "training.mp4").stat().st_size > 0 and (videos / "training.gif").stat().st_size > 0


class FolderHub:
    """The Hugging Face Hub's HTTP calls, answered from a folder: what would be uploaded is kept there to check."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def create_repo(self, api: HfApi, repo_id: str, **kwargs: Any) -> str:
        (self.root / repo_id).mkdir(parents=True, exist_ok=True)
        return f"https://huggingface.co/{repo_id}"

    def snapshot_download(self, api: HfApi, repo_id: str, *, local_dir: Any, **kwargs: Any) -> str:
        shutil.copytree(self.root / repo_id, local_dir, dirs_exist_ok=True)
        return str(local_dir)

    def upload_folder(self, api: HfApi, *, repo_id: str, folder_path: Any, **kwargs: Any) -> None:
        shutil.copytree(folder_path, self.root / repo_id, dirs_exist_ok=True)

    def hf_hub_download(self, repo_id: str, filename: str, **kwargs: Any) -> str:
        path = self.root / repo_id / filename
        if not path.is_file():
            # what huggingface_hub raises for a 404 on a file (its HTTP client's Response, whichever it is built on)
            http = importlib.import_module(HfHubHTTPError.__mro__[1].__module__.split(".")[0])
            response = http.Response(404, request=http.Request("GET", f"https://huggingface.co/{repo_id}/{filename}"))
            raise RemoteEntryNotFoundError(f"404: {filename}", response=response)
        return str(path)

    def install(self, monkeypatch: pytest.MonkeyPatch) -> None:
        for name in ("create_repo", "snapshot_download", "upload_folder"):
            function = getattr(self, name)
            monkeypatch.setattr(HfApi, name, lambda api, *args, _f=function, **kwargs: _f(api, *args, **kwargs))
        monkeypatch.setattr("huggingface_hub.hf_hub_download", self.hf_hub_download)


def test_push_to_hub_then_load_from_hub(logs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    hub = FolderHub(tmp_path / "hub_server")
    hub.install(monkeypatch)
    monkeypatch.chdir(tmp_path)
    run = logs / "reinforce" / f"{ENV_ID}_1"
    args = ["push_to_hub", "--algo", "reinforce", "--env", ENV_ID, "-f", str(logs), "--exp-id", "1", "-orga", "someone"]
    assert main([*args, "-n", "50"]) == 0

    uploaded = hub.root / "someone" / f"reinforce-{ENV_ID}"
    # the model, the same weights as the run's
    pushed, trained = REINFORCE.load(uploaded / f"reinforce-{ENV_ID}.zip"), REINFORCE.load(run / f"{ENV_ID}.zip")
    for name, tensor in trained.policy.state_dict().items():
        assert np.array_equal(tensor.numpy(), pushed.policy.state_dict()[name].numpy()), name
    # the zoo's config and arguments, as the run saved them
    for name in ("config.yml", "args.yml"):
        assert (uploaded / name).read_text() == (run / ENV_ID / name).read_text()
    assert yaml.safe_load((uploaded / "env_kwargs.yml").read_text()) == {"render_mode": "rgb_array"}
    with zipfile.ZipFile(uploaded / "train_eval_metrics.zip") as metrics:
        assert {"evaluations.npz", "0.monitor.csv"} <= set(metrics.namelist())
    evaluation = json.loads((uploaded / "results.json").read_text())
    assert evaluation["n_eval_episodes"] == 10 and evaluation["is_deterministic"]
    # the model card: metadata with the evaluation, usage lines that know --algo reinforce
    card = (uploaded / "README.md").read_text()
    assert card.startswith("---\n") and f"- {ENV_ID}" in card and "mean_reward" in card
    assert f"# **REINFORCE** Agent playing **{ENV_ID}**" in card
    assert f"sb3-reinforce-zoo enjoy --algo reinforce --env {ENV_ID}" in card and "python -m rl_zoo3" not in card
    assert 'pip install "sb3-reinforce[zoo]"' in card
    # the replay
    assert (uploaded / "replay.mp4").stat().st_size > 0

    # back from the Hub into the zoo's layout (without vec_normalize.pkl: the run has no VecNormalize), then enjoyed
    monkeypatch.setenv("TRUST_REMOTE_CODE", "True")
    args = ["load_from_hub", "--algo", "reinforce", "--env", ENV_ID, "-orga", "someone", "-f", "downloaded"]
    assert main(args) == 0
    downloaded = tmp_path / "downloaded" / "reinforce" / f"{ENV_ID}_1"
    assert (downloaded / ENV_ID / "config.yml").read_text() == (run / ENV_ID / "config.yml").read_text()
    assert not (downloaded / ENV_ID / "vecnormalize.pkl").exists()
    assert main(["enjoy", "--algo", "reinforce", "--env", ENV_ID, "-f", "downloaded", "--no-render", "-n", "50"]) == 0


def test_rl_trained_agents_is_found(logs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # -f rl-trained-agents: the current directory's when it has the agent, else the shipped one, else a clear error
    monkeypatch.chdir(tmp_path)
    assert trained_agents_dirs()[-1] == REPO / TRAINED_AGENTS
    local = tmp_path / TRAINED_AGENTS
    shutil.copytree(logs, local)
    assert agents_folder(TRAINED_AGENTS, "reinforce", ENV_ID) == TRAINED_AGENTS
    assert agents_folder(str(logs), "reinforce", "Pendulum-v1") == str(logs)  # another folder is left alone
    assert main(["enjoy", "--algo", "reinforce", "--env", ENV_ID, "--no-render", "-n", "50"]) == 0
    shutil.rmtree(local)
    if ENV_ID not in shipped_envs():
        assert agents_folder(TRAINED_AGENTS, "reinforce", ENV_ID) is None


def test_no_agent_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["enjoy", "--algo", "reinforce", "--env", "MountainCarContinuous-v0", "--no-render"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no trained REINFORCE agent for --env MountainCarContinuous-v0" in lines[0]
    assert f"shipped: {', '.join(shipped_envs()) or 'none'}" in lines[0]


@pytest.mark.parametrize("env_id", shipped_envs())
def test_shipped_agent_plays(env_id: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # each shipped agent is in the zoo's layout and is enjoyed from a folder without one (the installed package's case)
    monkeypatch.chdir(tmp_path)
    run = next(folder / "reinforce" / f"{env_id}_1" for folder in trained_agents_dirs() if (folder / "reinforce").is_dir())
    assert (run / f"{env_id}.zip").is_file() and (run / env_id / "config.yml").is_file()
    assert main(["enjoy", "--algo", "reinforce", "--env", env_id, "--no-render", "-n", "200"]) == 0
    # its video goes to ./videos/reinforce-<env>/, not into the shipped folder
    assert main(["record-video", "--algo", "reinforce", "--env", env_id, "-n", "50"]) == 0
    assert len(list((tmp_path / "videos" / f"reinforce-{env_id}").glob("*.mp4"))) == 1 and not (run / "videos").exists()


def test_shipped_config_by_name(tmp_path: Path) -> None:
    # `-conf reinforce_seed` is the shipped file, from a folder without zoo_configs/ (a wheel user's)
    args = ["train", "--algo", "reinforce", "--env", ENV_ID, "-n", "300", "-f", str(tmp_path), "-conf", "reinforce_seed"]
    assert main(args) == 0
    saved = yaml.load((tmp_path / "reinforce" / f"{ENV_ID}_1" / ENV_ID / "config.yml").read_text(), Loader=yaml.UnsafeLoader)
    seed_entry = yaml.safe_load((REPO / "zoo_configs" / "reinforce_seed.yml").read_text())[ENV_ID]
    assert dict(saved)["policy_kwargs"] == seed_entry["policy_kwargs"]


def test_tensorboard_flag(tmp_path: Path) -> None:
    # -tb (the zoo extra brings tensorboard): REINFORCE's training logs land as TensorBoard event files
    args = ["train", "--algo", "reinforce", "--env", ENV_ID, "-n", "600", "-f", str(tmp_path / "logs")]
    assert main([*args, "-tb", str(tmp_path / "tb")]) == 0
    events = list((tmp_path / "tb" / ENV_ID).glob("REINFORCE_1/events.out.tfevents.*"))
    assert len(events) == 1 and events[0].stat().st_size > 0


def test_track_flag_offline(tmp_path: Path) -> None:
    # --track (the zoo extra brings wandb), offline: the run is recorded locally (wandb-core talks over a Unix socket)
    env = dict(os.environ, WANDB_MODE="offline", WANDB_DIR=str(tmp_path), WANDB_SILENT="true", PYTHONPATH=str(REPO))
    args = ["train", "--algo", "reinforce", "--env", ENV_ID, "-n", "600", "-f", "logs", "--track", "--wandb-project-name", "t"]
    done = subprocess.run(
        [sys.executable, "-m", "sb3_reinforce.lab.zoo", *args], cwd=tmp_path, env=env, capture_output=True, timeout=300
    )
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    runs = list((tmp_path / "wandb").glob("offline-run-*"))
    assert len(runs) == 1 and list(runs[0].glob("*.wandb"))
    assert list((tmp_path / "runs").glob(f"{ENV_ID}__reinforce__*/{ENV_ID}/REINFORCE_1/events.out.tfevents.*"))
