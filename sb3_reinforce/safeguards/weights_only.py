"""
A weights-only model format that unpickles nothing.

SB3's ``.zip`` format (``model.save`` / ``REINFORCE.load``) stores some attributes with ``cloudpickle``:
loading such a file runs whatever code its author put in it. Only load ``.zip`` files you trust.

:func:`save_weights` / :func:`load_weights` write and read a different file, a zip archive with:

- ``config.json``: every hyperparameter (the table of
  :func:`~sb3_reinforce.reinforce.reinforce.hyperparameter_defaults`), the observation and action
  spaces described in JSON, the policy by its alias (``"MlpPolicy"``, ...), ``policy_kwargs`` limited to
  JSON values and names from fixed lists (activation function, optimizer, features extractor);
- ``weights.pt``: the policy's ``state_dict`` and the optimizer's, read with ``torch.load(weights_only=True)``,
  which refuses any pickled object other than tensors and plain containers.

Nothing in such a file is ever executed. What the format cannot describe (custom policy classes, learning rate
schedules, custom spaces) is refused at save time with an error naming it.
"""

import io
import json
import math
import pathlib
import warnings
import zipfile
import zlib
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.torch_layers import CombinedExtractor, FlattenExtractor, NatureCNN
from stable_baselines3.common.type_aliases import GymEnv
from torch import nn

from sb3_reinforce.reinforce.buffers import DictEpisodeRolloutBuffer, EpisodeRolloutBuffer
from sb3_reinforce.reinforce.reinforce import REINFORCE, hyperparameter_defaults

__all__ = ["CorruptModelFileError", "UnsafeFileError", "load_weights", "save_weights"]

FORMAT = "sb3-reinforce-weights"
#: 2: every hyperparameter, under "hyperparameters". 1 (still read): a fixed list of them, which lacked
#: n_value_steps, value_learning_rate and a few others (loaded at their defaults, with a warning).
FORMAT_VERSION = 2

# Names that a weights-only file may use for classes; nothing else is ever looked up.
ACTIVATIONS: dict[str, type[nn.Module]] = {
    cls.__name__: cls for cls in (nn.Tanh, nn.ReLU, nn.ELU, nn.LeakyReLU, nn.GELU, nn.SiLU, nn.Sigmoid, nn.Identity)
}
OPTIMIZERS: dict[str, type[th.optim.Optimizer]] = {
    cls.__name__: cls for cls in (th.optim.Adam, th.optim.AdamW, th.optim.RMSprop, th.optim.SGD)
}
EXTRACTORS: dict[str, type[nn.Module]] = {cls.__name__: cls for cls in (FlattenExtractor, NatureCNN, CombinedExtractor)}
_CLASS_KWARGS: dict[str, dict[str, type]] = {
    "activation_fn": ACTIVATIONS,
    "optimizer_class": OPTIMIZERS,
    "features_extractor_class": EXTRACTORS,
}
ROLLOUT_BUFFERS: dict[str, type[EpisodeRolloutBuffer]] = {
    cls.__name__: cls for cls in (EpisodeRolloutBuffer, DictEpisodeRolloutBuffer)
}
#: Stored as numbers, or refused: a schedule (a callable) is code.
_LEARNING_RATES = ("learning_rate", "value_learning_rate")


class CorruptModelFileError(ValueError):
    """A weights-only file is truncated, corrupted, or not a weights-only file at all."""


class UnsafeFileError(ValueError):
    """A weights-only file holds something that the weights-only format does not allow."""


# --- spaces as JSON ---------------------------------------------------------------------------------
def _float_list(values: np.ndarray) -> list[float | str]:
    # JSON has no inf/nan: write them as strings
    return [float(v) if math.isfinite(v) else str(float(v)) for v in values.astype(np.float64).ravel()]


def _float_array(values: list[Any], shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    if not all(isinstance(v, (int, float)) or v in ("inf", "-inf", "nan") for v in values):
        raise UnsafeFileError("Box bounds must be numbers or 'inf'/'-inf'/'nan'")
    return np.array([float(v) for v in values], dtype=np.float64).reshape(shape).astype(dtype)


def space_to_json(space: spaces.Space) -> dict[str, Any]:
    """
    Describe a space with JSON values only.

    :param space: ``Box``, ``Discrete``, ``MultiDiscrete``, ``MultiBinary`` or a ``Dict`` of those
    :return: The description, which :func:`space_from_json` turns back into an equal space
    """
    if isinstance(space, spaces.Box):
        return {
            "type": "Box",
            "shape": list(space.shape),
            "dtype": str(space.dtype),
            "low": _float_list(space.low),
            "high": _float_list(space.high),
        }
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, spaces.MultiDiscrete):
        return {"type": "MultiDiscrete", "nvec": space.nvec.tolist(), "start": space.start.tolist()}
    if isinstance(space, spaces.MultiBinary):
        return {"type": "MultiBinary", "n": [int(n) for n in np.atleast_1d(space.n)]}
    if isinstance(space, spaces.Dict):
        return {"type": "Dict", "spaces": {key: space_to_json(sub) for key, sub in space.spaces.items()}}
    raise UnsafeFileError(f"The weights-only format cannot describe the space {space!r}")


def space_from_json(description: dict[str, Any]) -> spaces.Space:
    """
    Build a space from :func:`space_to_json`'s description.

    :param description: The description
    :return: The space
    :raises UnsafeFileError: if the description is not one that :func:`space_to_json` writes
    """
    if not isinstance(description, dict):
        raise UnsafeFileError(f"A space description must be a JSON object, got {description!r}")
    kind = description.get("type")
    if kind == "Box":
        shape = tuple(int(n) for n in description["shape"])
        dtype = np.dtype(description["dtype"])
        if dtype.kind not in "fiu":
            raise UnsafeFileError(f"Box dtype must be numeric, got {dtype}")
        low = _float_array(description["low"], shape, dtype)
        high = _float_array(description["high"], shape, dtype)
        return spaces.Box(low, high, shape=shape, dtype=dtype)
    if kind == "Discrete":
        return spaces.Discrete(int(description["n"]), start=int(description["start"]))
    if kind == "MultiDiscrete":
        return spaces.MultiDiscrete(np.array(description["nvec"], dtype=np.int64), start=np.array(description["start"]))
    if kind == "MultiBinary":
        n = [int(v) for v in description["n"]]
        return spaces.MultiBinary(n[0] if len(n) == 1 else n)
    if kind == "Dict":
        return spaces.Dict({str(key): space_from_json(sub) for key, sub in description["spaces"].items()})
    raise UnsafeFileError(f"Unknown space type {kind!r} in a weights-only file")


# --- the weights-only format ------------------------------------------------------------------------
def _json_value(what: str, value: Any) -> Any:
    """``value`` if a JSON round trip gives it back unchanged, else an ``UnsafeFileError`` naming ``what``."""
    try:
        if json.loads(json.dumps(value)) != value:
            raise TypeError("changed by a JSON round trip (tuples?)")
    except (TypeError, ValueError) as exc:
        raise UnsafeFileError(
            f"{what} = {value!r} is not a JSON value: the weights-only format cannot store it ({exc})"
        ) from exc
    return value


def _policy_kwargs_to_json(policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in policy_kwargs.items():
        if key in _CLASS_KWARGS:
            allowed = _CLASS_KWARGS[key]
            name = getattr(value, "__name__", "")
            if allowed.get(name) is not value:
                raise UnsafeFileError(
                    f"policy_kwargs[{key!r}] = {value!r} cannot be saved in the weights-only format, "
                    f"which allows {sorted(allowed)}"
                )
            result[key] = name
            continue
        result[key] = _json_value(f"policy_kwargs[{key!r}]", value)
    return result


def _policy_kwargs_from_json(policy_kwargs: Any) -> dict[str, Any]:
    if not isinstance(policy_kwargs, dict):
        raise UnsafeFileError("policy_kwargs must be a JSON object")
    result = dict(policy_kwargs)
    for key, allowed in _CLASS_KWARGS.items():
        if key in result:
            if result[key] not in allowed:
                raise UnsafeFileError(f"policy_kwargs[{key!r}] must be one of {sorted(allowed)}, got {result[key]!r}")
            result[key] = allowed[result[key]]
    return result


def _hyperparameter_to_json(model: REINFORCE, name: str) -> Any:
    value = getattr(model, "_stats_window_size" if name == "stats_window_size" else name)
    if name in _LEARNING_RATES:
        if callable(value):
            raise UnsafeFileError(f"`{name}` is a schedule (a callable), which the weights-only format cannot store")
        return None if value is None else float(value)
    if name == "policy_kwargs":
        return _policy_kwargs_to_json(value)
    if name == "rollout_buffer_class":
        if ROLLOUT_BUFFERS.get(getattr(value, "__name__", "")) is not value:
            raise UnsafeFileError(
                f"rollout_buffer_class={value!r} cannot be saved in the weights-only format, "
                f"which allows {sorted(ROLLOUT_BUFFERS)}"
            )
        return getattr(value, "__name__", None)
    if name == "tensorboard_log" and value is not None:
        return str(value)
    return _json_value(f"`{name}`", value)


def _hyperparameter_from_json(name: str, value: Any) -> Any:
    if name in _LEARNING_RATES:
        if value is not None and not isinstance(value, (int, float)):
            raise UnsafeFileError(f"`{name}` must be a number in a weights-only file, got {value!r}")
        return value
    if name == "policy_kwargs":
        return _policy_kwargs_from_json(value)
    if name == "rollout_buffer_class":
        if value not in ROLLOUT_BUFFERS:
            raise UnsafeFileError(f"rollout_buffer_class must be one of {sorted(ROLLOUT_BUFFERS)}, got {value!r}")
        return ROLLOUT_BUFFERS[value]
    return value


def save_weights(model: REINFORCE, path: str | pathlib.Path) -> None:
    """
    Save a REINFORCE model in the weights-only format (see the module docstring). Load it with :func:`load_weights`.

    Saved: every hyperparameter, the spaces, the policy's and the optimizer's ``state_dict`` (and the value
    steps' optimizer's), ``num_timesteps`` and the number of updates. Not saved: the episode statistics, the
    logger, the environment, the random generators.

    :param model: The model
    :param path: Where to write the file (a zip archive; no suffix is added)
    :raises UnsafeFileError: if the model uses something the format cannot describe (it names it)
    """
    alias = next((name for name, cls in model.policy_aliases.items() if cls is model.policy_class), None)
    if alias is None:
        raise UnsafeFileError(
            f"Policy class {model.policy_class!r} has no alias in REINFORCE.policy_aliases: "
            "the weights-only format only names policies by alias"
        )
    config = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "algorithm": "REINFORCE",
        "policy": alias,
        "hyperparameters": {name: _hyperparameter_to_json(model, name) for name in hyperparameter_defaults()},
        "observation_space": space_to_json(model.observation_space),
        "action_space": space_to_json(model.action_space),
        "num_timesteps": int(model.num_timesteps),
        "n_updates": int(model._n_updates),
    }
    state = {"policy": model.policy.state_dict(), "optimizer": model.policy.optimizer.state_dict()}
    if model.value_optimizer is not None:
        state["value_optimizer"] = model.value_optimizer.state_dict()
    buffer = io.BytesIO()
    th.save(state, buffer)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("config.json", json.dumps(config, indent=1))
        archive.writestr("weights.pt", buffer.getvalue())


def _read_hyperparameters(path: str | pathlib.Path, config: dict[str, Any]) -> dict[str, Any]:
    """The hyperparameters of a weights-only file's ``config.json``, a version 1 file's missing ones at their defaults."""
    defaults = hyperparameter_defaults()
    hyperparameters = config.get("hyperparameters")
    if not isinstance(hyperparameters, dict) or set(hyperparameters) - set(defaults):
        raise UnsafeFileError(f"{path}: hyperparameters must be a JSON object with keys among {sorted(defaults)}")
    if config["format_version"] == 1:  # learning_rate and policy_kwargs stood beside the hyperparameters
        hyperparameters = {
            **hyperparameters,
            "learning_rate": config.get("learning_rate"),
            "policy_kwargs": config.get("policy_kwargs", {}),
        }
        missing = [name for name in defaults if name not in hyperparameters]
        warnings.warn(
            f"{path} is a weights-only file of format version 1, which did not store {missing}: they are loaded at "
            f"their defaults ({', '.join(f'{name}={defaults[name]!r}' for name in missing)}). Save it again to keep them.",
            stacklevel=3,
        )
    return {name: _hyperparameter_from_json(name, value) for name, value in hyperparameters.items()}


def _read_archive(path: str | pathlib.Path) -> tuple[dict[str, Any], bytes]:
    """
    The parsed ``config.json`` of a weights-only file (its format, version and policy checked) and ``weights.pt``'s bytes.

    :raises CorruptModelFileError: if the file is not an intact weights-only file
    :raises UnsafeFileError: if ``config.json`` is not of this format or names another policy
    """
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            if "config.json" not in names or "weights.pt" not in names:
                raise CorruptModelFileError(
                    f"{path} is not a weights-only file (members: {names}); SB3 .zip files are loaded with REINFORCE.load"
                )
            config = json.loads(archive.read("config.json").decode())
            weights_bytes = archive.read("weights.pt")
    except (zipfile.BadZipFile, zlib.error, EOFError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CorruptModelFileError(f"Cannot load {path}: truncated or corrupted ({type(exc).__name__}: {exc})") from exc
    if (
        not isinstance(config, dict)
        or config.get("format") != FORMAT
        or config.get("format_version") not in (1, FORMAT_VERSION)
    ):
        raise UnsafeFileError(f"{path}: config.json is not a {FORMAT} description of version 1 or {FORMAT_VERSION}")
    if config.get("policy") not in REINFORCE.policy_aliases:
        raise UnsafeFileError(f"{path}: unknown policy {config.get('policy')!r}, allowed: {sorted(REINFORCE.policy_aliases)}")
    return config, weights_bytes


def _read_state_dicts(path: str | pathlib.Path, weights_bytes: bytes) -> dict[str, Any]:
    """
    ``weights.pt``'s state_dicts, read with ``torch.load(weights_only=True)``.

    :raises UnsafeFileError: if it holds anything but tensors, numbers, strings and plain containers, or no policy
    """
    try:
        # weights_only=True: tensors, numbers, strings and plain containers only; any other pickled object raises.
        weights = th.load(io.BytesIO(weights_bytes), map_location="cpu", weights_only=True)
    except Exception as exc:
        raise UnsafeFileError(
            f"{path}: weights.pt is not a plain state_dict file, refused by torch.load(weights_only=True) "
            f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
        ) from exc
    if not isinstance(weights, dict) or not isinstance(weights.get("policy"), dict):
        raise UnsafeFileError(f"{path}: weights.pt must hold a dict with a 'policy' state_dict")
    return weights


def load_weights(
    path: str | pathlib.Path, env: GymEnv | None = None, device: th.device | str = "auto", load_optimizer: bool = True
) -> REINFORCE:
    """
    Load a model saved by :func:`save_weights`, unpickling nothing: ``config.json`` is parsed as JSON and
    ``weights.pt`` is read with ``torch.load(weights_only=True)``. A file of format version 1 (which stored a
    fixed list of hyperparameters) loads too, the missing ones at their defaults, with a warning naming them.

    :param path: The file
    :param env: The environment to train on (its spaces must match the saved ones), or None to only predict
    :param device: Device for the model
    :param load_optimizer: Whether to restore the optimizers' states (Adam moments) as well
    :return: The model
    :raises CorruptModelFileError: if the file is not an intact weights-only file
    :raises UnsafeFileError: if the file names a class, space or value outside the format
    """
    config, weights_bytes = _read_archive(path)
    hyperparameters = _read_hyperparameters(path, config)
    observation_space = space_from_json(config["observation_space"])
    action_space = space_from_json(config["action_space"])
    weights = _read_state_dicts(path, weights_bytes)

    model = REINFORCE(config["policy"], env, device=device, _init_setup_model=False, **hyperparameters)  # type: ignore[arg-type]
    if env is None:
        model.observation_space, model.action_space, model.n_envs = observation_space, action_space, 1
    elif model.observation_space != observation_space or model.action_space != action_space:
        raise ValueError(
            f"The environment's spaces ({model.observation_space}, {model.action_space}) differ from the saved ones "
            f"({observation_space}, {action_space})"
        )
    model._setup_model()
    model.policy.load_state_dict(weights["policy"])
    if load_optimizer and "optimizer" in weights:
        model.policy.optimizer.load_state_dict(weights["optimizer"])
    if load_optimizer and model.value_optimizer is not None and "value_optimizer" in weights:
        model.value_optimizer.load_state_dict(weights["value_optimizer"])
    model.num_timesteps = int(config.get("num_timesteps", 0))
    model._n_updates = int(config.get("n_updates", 0))
    return model
