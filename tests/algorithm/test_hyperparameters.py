"""One table of REINFORCE's hyperparameters, derived from its signature: checks, both save formats, the zoo."""

import inspect
import json
import pathlib
import zipfile

import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE, EpisodeRolloutBuffer
from sb3_reinforce.reinforce.reinforce import (
    ALLOWED_VALUES,
    NOT_HYPERPARAMETERS,
    check_hyperparameters,
    hyperparameter_defaults,
)
from sb3_reinforce.safeguards import load_weights, save_weights

#: A value other than the default for every hyperparameter (valid together; Pendulum, for gSDE).
NON_DEFAULTS = {
    "learning_rate": 5e-4,
    "n_episodes": 3,
    "min_steps": 7,
    "gamma": 0.97,
    "baseline": "value",
    "normalize_returns": False,
    "ent_coef": 0.01,
    "vf_coef": 0.3,
    "n_value_steps": 4,
    "value_learning_rate": 2e-3,
    "max_grad_norm": 0.7,
    "use_sde": True,
    "sde_sample_freq": 4,
    "max_rollout_steps": 50_000,
    "rollout_buffer_class": EpisodeRolloutBuffer,
    "rollout_buffer_kwargs": {"buffer_size": 512},
    "stats_window_size": 17,
    "tensorboard_log": "tensorboard_logs",
    "policy_kwargs": {"net_arch": [16], "log_std_init": -1.0},
    "verbose": 1,
    "seed": 3,
}


def _setting(model: REINFORCE, name: str) -> object:
    return getattr(model, "_stats_window_size" if name == "stats_window_size" else name)


def test_the_table_is_the_signature() -> None:
    parameters = inspect.signature(REINFORCE).parameters
    assert list(hyperparameter_defaults()) == [name for name in parameters if name not in NOT_HYPERPARAMETERS]
    assert hyperparameter_defaults()["n_value_steps"] == 0
    assert list(ALLOWED_VALUES) == list(hyperparameter_defaults())  # every hyperparameter is checked


def test_non_defaults_cover_every_hyperparameter() -> None:
    defaults = hyperparameter_defaults()
    assert set(NON_DEFAULTS) == set(defaults), "a new constructor argument needs a non-default value here"
    assert all(NON_DEFAULTS[name] != default for name, default in defaults.items())


@pytest.mark.parametrize("save_format", ["sb3_zip", "weights_only"])
def test_every_setting_survives_a_round_trip(tmp_path: pathlib.Path, save_format: str) -> None:
    kwargs = {**NON_DEFAULTS, "tensorboard_log": str(tmp_path / NON_DEFAULTS["tensorboard_log"])}
    model = REINFORCE("MlpPolicy", "Pendulum-v1", **kwargs)
    model.learn(600)
    if save_format == "sb3_zip":
        model.save(tmp_path / "model.zip")
        loaded = REINFORCE.load(tmp_path / "model.zip")
    else:
        save_weights(model, tmp_path / "weights.zip")
        loaded = load_weights(tmp_path / "weights.zip")
    for name, value in kwargs.items():
        assert _setting(loaded, name) == value, name
    assert loaded.value_optimizer is not None  # the value steps, not the joint update
    for saved, restored in ((model.policy, loaded.policy), (model.value_optimizer, loaded.value_optimizer)):
        saved_state, restored_state = saved.state_dict(), restored.state_dict()
        assert json.dumps(saved_state.get("param_groups", []), default=str) == json.dumps(
            restored_state.get("param_groups", []), default=str
        )
    for key, tensor in model.policy.state_dict().items():
        assert th.equal(tensor, loaded.policy.state_dict()[key]), key


def test_weights_only_file_of_version_1_loads_with_a_warning(tmp_path: pathlib.Path) -> None:
    model = REINFORCE("MlpPolicy", "CartPole-v1", baseline="value", n_value_steps=20, value_learning_rate=1e-3, seed=0)
    save_weights(model, tmp_path / "v2.zip")
    with zipfile.ZipFile(tmp_path / "v2.zip") as archive:
        config, weights = json.loads(archive.read("config.json")), archive.read("weights.pt")
    # version 1 wrote learning_rate and policy_kwargs beside a fixed list of hyperparameters
    version_1_names = ["n_episodes", "min_steps", "gamma", "baseline", "normalize_returns", "ent_coef", "vf_coef"]
    version_1_names += ["max_grad_norm", "use_sde", "sde_sample_freq", "max_rollout_steps", "stats_window_size", "seed"]
    hyperparameters = config["hyperparameters"]
    config.update(
        format_version=1,
        learning_rate=hyperparameters["learning_rate"],
        policy_kwargs=hyperparameters["policy_kwargs"],
        hyperparameters={name: hyperparameters[name] for name in version_1_names},
    )
    with zipfile.ZipFile(tmp_path / "v1.zip", "w") as archive:
        archive.writestr("config.json", json.dumps(config))
        archive.writestr("weights.pt", weights)
    with pytest.warns(UserWarning, match=r"format version 1.*'n_value_steps'.*n_value_steps=0"):
        loaded = load_weights(tmp_path / "v1.zip", env=DummyVecEnv([lambda: model.get_env().envs[0]]))  # type: ignore[union-attr]
    assert loaded.n_value_steps == 0 and loaded.value_learning_rate is None  # the defaults, as the warning says
    assert loaded.baseline == "value" and loaded.seed == 0
    for key, tensor in model.policy.state_dict().items():
        assert th.equal(tensor, loaded.policy.state_dict()[key]), key


def test_unknown_hyperparameter_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"Unknown REINFORCE hyperparameters \['n_steps'\]"):
        check_hyperparameters({"n_steps": 5})
