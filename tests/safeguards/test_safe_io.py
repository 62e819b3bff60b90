"""Untrusted files: damaged SB3 zips never load (SB3's errors); the weights-only format never unpickles objects."""

import base64
import io
import json
import os
import pathlib
import pickle
import zipfile

import cloudpickle
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.envs import IdentityEnv, IdentityEnvBox, SimpleMultiObsEnv
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards.weights_only import (
    CorruptModelFileError,
    UnsafeFileError,
    load_weights,
    save_weights,
    space_from_json,
    space_to_json,
)


class Booby:
    """Unpickling this creates a marker file: the proof that a loader executed code from the file."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self) -> tuple:
        return (open, (self.marker, "w"))


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    path = tmp_path_factory.mktemp("zip") / "model.zip"
    REINFORCE("MlpPolicy", "CartPole-v1", seed=0).learn(100).save(path)
    return path


@pytest.mark.parametrize("keep", [0.0, 0.3, 0.9, 0.999])
def test_truncated_zip_clear_error(tmp_path: pathlib.Path, saved: pathlib.Path, keep: float) -> None:
    data = saved.read_bytes()
    (tmp_path / "cut.zip").write_bytes(data[: int(len(data) * keep)])
    # SB3's errors: "wasn't a zip-file" (ValueError) without a readable central directory, else "No data found"
    with pytest.raises((ValueError, AssertionError), match=r"cut\.zip wasn't a zip-file|No data found"):
        REINFORCE.load(tmp_path / "cut.zip")


@pytest.mark.parametrize("seed", range(6))
def test_corrupted_zip_clear_error(tmp_path: pathlib.Path, saved: pathlib.Path, seed: int) -> None:
    data = bytearray(saved.read_bytes())
    rng = np.random.default_rng(seed)
    with zipfile.ZipFile(saved) as archive:  # flip bytes inside the members' data, where SB3 would not notice
        info = archive.getinfo("policy.pth" if seed % 2 else "data")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    for pos in rng.integers(start, start + info.compress_size, size=3):
        data[pos] ^= 0xFF
    (tmp_path / "bad.zip").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"bad\.zip wasn't a zip-file"):  # SB3's, on the members' CRC or zlib error
        REINFORCE.load(tmp_path / "bad.zip")


def test_not_a_model_zip(tmp_path: pathlib.Path) -> None:
    with zipfile.ZipFile(tmp_path / "other.zip", "w") as archive:
        archive.writestr("readme.txt", "hello")
    with pytest.raises(AssertionError, match="No data found"):  # SB3's
        REINFORCE.load(tmp_path / "other.zip")
    with pytest.raises(FileNotFoundError):
        REINFORCE.load(tmp_path / "missing.zip")


def _booby_trapped_sb3_zip(saved: pathlib.Path, target: pathlib.Path, marker: pathlib.Path) -> None:
    with zipfile.ZipFile(saved) as source, zipfile.ZipFile(target, "w") as archive:
        for item in source.namelist():
            content = source.read(item)
            if item == "data":
                data = json.loads(content)
                payload = base64.b64encode(cloudpickle.dumps(Booby(str(marker)))).decode()
                data["ep_info_buffer"] = {":type:": "<class 'object'>", ":serialized:": payload}
                content = json.dumps(data).encode()
            archive.writestr(item, content)


def test_sb3_zip_runs_code_as_the_readme_says(tmp_path: pathlib.Path, saved: pathlib.Path) -> None:
    """The README's warning is true: SB3's format unpickles, so a crafted .zip runs code on load."""
    marker = tmp_path / "pwned"
    _booby_trapped_sb3_zip(saved, tmp_path / "trap.zip", marker)
    try:
        REINFORCE.load(tmp_path / "trap.zip")
    except Exception:  # whatever happens after the unpickling, the code already ran
        pass
    assert marker.exists()


def _params(model: REINFORCE) -> list[th.Tensor]:
    return [p.detach().clone() for p in model.policy.parameters()]


@pytest.mark.parametrize(
    "make_env, policy, kwargs",
    [
        (
            lambda: IdentityEnv(4),
            "MlpPolicy",
            dict(baseline="value", policy_kwargs=dict(net_arch=[8], activation_fn=th.nn.ReLU)),
        ),
        (
            lambda: IdentityEnvBox(eps=0.5),
            "MlpPolicy",
            dict(gamma=0.5, policy_kwargs=dict(log_std_init=-0.5, xavier_init=True)),
        ),
        (lambda: SimpleMultiObsEnv(random_start=False), "MultiInputPolicy", dict(n_episodes=2, max_grad_norm=1.0)),
    ],
)
def test_weights_only_round_trip(tmp_path: pathlib.Path, make_env, policy: str, kwargs: dict) -> None:
    env = DummyVecEnv([make_env])
    model = REINFORCE(policy, env, seed=1, **kwargs).learn(200)
    save_weights(model, tmp_path / "weights.zip")
    with zipfile.ZipFile(tmp_path / "weights.zip") as archive:
        assert sorted(archive.namelist()) == ["config.json", "weights.pt"]

    loaded = load_weights(tmp_path / "weights.zip")  # no env: predict only
    assert all(th.equal(a, b) for a, b in zip(_params(model), _params(loaded), strict=True))
    assert loaded.observation_space == model.observation_space and loaded.action_space == model.action_space
    for name in ("gamma", "n_episodes", "baseline", "max_grad_norm", "num_timesteps", "_n_updates"):
        assert getattr(loaded, name) == getattr(model, name), name
    obs = env.reset()
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0])

    # With an env: the optimizer state (Adam moments) is back and training continues
    trained = load_weights(tmp_path / "weights.zip", env=DummyVecEnv([make_env]))
    for a, b in zip(
        trained.policy.optimizer.state_dict()["state"].values(),
        model.policy.optimizer.state_dict()["state"].values(),
        strict=True,
    ):
        assert th.equal(a["exp_avg"], b["exp_avg"]) and th.equal(a["exp_avg_sq"], b["exp_avg_sq"])
    trained.learn(100, reset_num_timesteps=False)
    assert trained.num_timesteps > model.num_timesteps


def test_weights_only_refuses_what_it_cannot_describe(tmp_path: pathlib.Path) -> None:
    with pytest.raises(UnsafeFileError, match="activation_fn"):
        save_weights(REINFORCE("MlpPolicy", "CartPole-v1", policy_kwargs=dict(activation_fn=th.nn.Hardtanh)), tmp_path / "w")
    with pytest.raises(UnsafeFileError, match="schedule"):
        save_weights(REINFORCE("MlpPolicy", "CartPole-v1", learning_rate=lambda p: 1e-3 * p), tmp_path / "w")
    model = REINFORCE("MlpPolicy", "CartPole-v1")
    save_weights(model, tmp_path / "w.zip")
    with pytest.raises(ValueError, match="spaces"):
        load_weights(tmp_path / "w.zip", env=DummyVecEnv([lambda: IdentityEnv(3)]))


def _rewrite(path: pathlib.Path, target: pathlib.Path, member: str, content: bytes) -> None:
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(target, "w") as archive:
        for item in source.namelist():
            archive.writestr(item, content if item == member else source.read(item))


def test_booby_trapped_pickle_is_not_executed(tmp_path: pathlib.Path) -> None:
    """A weights.pt holding a pickle that would create a file: load_weights refuses it, the file never appears."""
    model = REINFORCE("MlpPolicy", "CartPole-v1", seed=0)
    save_weights(model, tmp_path / "w.zip")
    marker = tmp_path / "pwned"

    # 1. a torch file whose state_dict holds the trap, 2. a raw pickle instead of a torch file
    trapped = io.BytesIO()
    th.save({"policy": {"weight": Booby(str(marker))}}, trapped)
    for name, payload in (("torch_save", trapped.getvalue()), ("raw_pickle", pickle.dumps(Booby(str(marker))))):
        _rewrite(tmp_path / "w.zip", tmp_path / f"{name}.zip", "weights.pt", payload)
        with pytest.raises(UnsafeFileError, match=r"weights_only=True"):
            load_weights(tmp_path / f"{name}.zip")
        assert not marker.exists()

    # 3. an SB3 .zip with a trapped `data` member: not a weights-only file, nothing read
    REINFORCE("MlpPolicy", "CartPole-v1").save(tmp_path / "sb3.zip")
    _booby_trapped_sb3_zip(tmp_path / "sb3.zip", tmp_path / "trap.zip", marker)
    with pytest.raises(CorruptModelFileError, match="not a weights-only file"):
        load_weights(tmp_path / "trap.zip")
    assert not marker.exists()
    # the control: the same trap does fire through torch's full unpickler, so the test can fail
    with pytest.raises(Exception):  # noqa: B017
        th.load(io.BytesIO(pickle.dumps(Booby(str(marker)))), weights_only=False)
    assert marker.exists()


@pytest.mark.parametrize(
    "config_change, match",
    [
        (dict(policy="os.system"), "unknown policy"),
        (dict(policy_kwargs=dict(activation_fn="builtins.eval")), "activation_fn"),
        (dict(policy_kwargs=dict(optimizer_class="subprocess.Popen")), "optimizer_class"),
        (dict(observation_space=dict(type="Tuple")), "Unknown space type"),
        (dict(observation_space=dict(type="Box", shape=[1], dtype="object", low=[0], high=[1])), "dtype"),
        (dict(hyperparameters=dict(policy_class="x")), "hyperparameters"),
        (dict(format="pickle"), "description"),
    ],
)
def test_weights_only_config_is_checked(tmp_path: pathlib.Path, config_change: dict, match: str) -> None:
    save_weights(REINFORCE("MlpPolicy", "CartPole-v1"), tmp_path / "w.zip")
    with zipfile.ZipFile(tmp_path / "w.zip") as archive:
        config = json.loads(archive.read("config.json"))
    for key, value in config_change.items():  # policy_kwargs is one of the hyperparameters
        (config["hyperparameters"] if key == "policy_kwargs" else config)[key] = value
    _rewrite(tmp_path / "w.zip", tmp_path / "bad.zip", "config.json", json.dumps(config).encode())
    with pytest.raises(UnsafeFileError, match=match):
        load_weights(tmp_path / "bad.zip")


def test_weights_only_damaged_file(tmp_path: pathlib.Path) -> None:
    save_weights(REINFORCE("MlpPolicy", "CartPole-v1"), tmp_path / "w.zip")
    data = (tmp_path / "w.zip").read_bytes()
    (tmp_path / "cut.zip").write_bytes(data[: len(data) // 2])
    with pytest.raises(CorruptModelFileError, match="truncated or corrupted"):
        load_weights(tmp_path / "cut.zip")


@pytest.mark.parametrize(
    "space",
    [
        spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64),
        spaces.Box(np.array([0, -1], dtype=np.float32), np.array([1, 2], dtype=np.float32)),
        spaces.Box(0, 255, shape=(4, 4, 1), dtype=np.uint8),
        spaces.Discrete(5, start=-2),
        spaces.MultiDiscrete([2, 3], start=[1, 0]),
        spaces.MultiBinary(4),
        spaces.MultiBinary([2, 3]),
        spaces.Dict({"a": spaces.Discrete(3), "b": spaces.Box(-1, 1, shape=(2,))}),
    ],
)
def test_space_json_round_trip(space: spaces.Space) -> None:
    assert space_from_json(json.loads(json.dumps(space_to_json(space)))) == space


def test_no_file_written_outside(tmp_path: pathlib.Path) -> None:
    # load_weights reads the archive in memory: it extracts nothing to disk
    save_weights(REINFORCE("MlpPolicy", "CartPole-v1"), tmp_path / "w.zip")
    before = set(os.listdir(tmp_path))
    load_weights(tmp_path / "w.zip")
    assert set(os.listdir(tmp_path)) == before
