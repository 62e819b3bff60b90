"""
Safe loading: clear errors for damaged model files, and a weights-only format that unpickles nothing.

SB3's ``.zip`` format (``model.save`` / ``REINFORCE.load``) stores some attributes with ``cloudpickle``:
loading such a file runs whatever code its author put in it. Only load ``.zip`` files you trust.

:func:`save_weights` / :func:`load_weights` write and read a different file, a zip archive with:

- ``config.json``: the hyperparameters, the observation and action spaces described in JSON, the policy by
  its alias (``"MlpPolicy"``, ...) and ``policy_kwargs`` limited to JSON values and names from fixed lists
  (activation function, optimizer, features extractor);
- ``weights.pt``: the policy's ``state_dict`` and the optimizer's, read with ``torch.load(weights_only=True)``,
  which refuses any pickled object other than tensors and plain containers.

Nothing in such a file is ever executed. What the format cannot describe (custom policy classes, learning rate
schedules, custom spaces) is refused at save time with an error naming it.
"""

import io
import json
import math
import pathlib
import zipfile
import zlib
from typing import IO, TYPE_CHECKING, Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.torch_layers import CombinedExtractor, FlattenExtractor, NatureCNN
from stable_baselines3.common.type_aliases import GymEnv
from torch import nn

if TYPE_CHECKING:
    from sb3_reinforce.reinforce import REINFORCE

__all__ = ["CorruptModelFileError", "UnsafeFileError", "check_model_file", "load_weights", "save_weights"]

FORMAT = "sb3-reinforce-weights"
FORMAT_VERSION = 1

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
# REINFORCE's constructor arguments stored in config.json (learning_rate is checked separately)
_HYPERPARAMETERS = (
    "n_episodes",
    "min_steps",
    "gamma",
    "baseline",
    "normalize_returns",
    "ent_coef",
    "vf_coef",
    "max_grad_norm",
    "use_sde",
    "sde_sample_freq",
    "max_rollout_steps",
    "stats_window_size",
    "seed",
)


class CorruptModelFileError(ValueError):
    """A model file is truncated, corrupted, or not a model file at all."""


class UnsafeFileError(ValueError):
    """A weights-only file holds something that the weights-only format does not allow."""


# --- checking SB3 .zip files ------------------------------------------------------------------------
def check_model_file(path: str | pathlib.Path | io.BufferedIOBase | IO[bytes]) -> None:
    """
    Check that an SB3 model ``.zip`` is intact before SB3 reads it: a readable zip archive whose members
    pass their CRC checks, with a ``data`` member that is valid JSON and a ``policy.pth`` member.
    This checks integrity only: it does not make a file from an untrusted source safe to load.

    :param path: The file (``.zip`` is appended when the path does not exist, as SB3 does), or an open file
    :raises CorruptModelFileError: naming the file and what is wrong with it
    """
    if isinstance(path, (str, pathlib.Path)):
        path = pathlib.Path(path)
        if not path.exists() and path.with_name(path.name + ".zip").exists():
            path = path.with_name(path.name + ".zip")
        if not path.exists():
            return  # SB3 raises its own FileNotFoundError
        name = str(path)
    else:
        name = getattr(path, "name", repr(path))
        start = path.tell()
    try:
        with zipfile.ZipFile(path) as archive:
            damaged = archive.testzip()
            if damaged is not None:
                raise CorruptModelFileError(f"Cannot load {name}: member {damaged!r} fails its CRC check (corrupted file)")
            missing = [member for member in ("data", "policy.pth") if member not in archive.namelist()]
            if missing:
                raise CorruptModelFileError(
                    f"Cannot load {name}: the file is truncated or corrupted, or not an SB3 model file "
                    f"(it has no {missing} member)"
                )
            json.loads(archive.read("data").decode())
    except (zipfile.BadZipFile, zlib.error, EOFError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CorruptModelFileError(
            f"Cannot load {name}: the file is truncated or corrupted ({type(exc).__name__}: {exc})"
        ) from exc
    finally:
        if not isinstance(path, pathlib.Path):
            path.seek(start)


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
        try:
            if json.loads(json.dumps(value)) != value:
                raise TypeError("changed by a JSON round trip (tuples?)")
        except (TypeError, ValueError) as exc:
            raise UnsafeFileError(
                f"policy_kwargs[{key!r}] = {value!r} is not a JSON value: the weights-only format cannot store it ({exc})"
            ) from exc
        result[key] = value
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


def save_weights(model: "REINFORCE", path: str | pathlib.Path) -> None:
    """
    Save a REINFORCE model in the weights-only format (see the module docstring). Load it with :func:`load_weights`.

    Saved: the hyperparameters, the spaces, the policy's and the optimizer's ``state_dict``, ``num_timesteps`` and
    the number of updates. Not saved: the episode statistics, the logger, the environment, the random generators.

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
    if callable(model.learning_rate):
        raise UnsafeFileError("A learning-rate schedule (a callable) cannot be stored in the weights-only format")
    config = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "algorithm": "REINFORCE",
        "policy": alias,
        "learning_rate": float(model.learning_rate),
        "hyperparameters": {
            name: getattr(model, "_stats_window_size" if name == "stats_window_size" else name) for name in _HYPERPARAMETERS
        },
        "policy_kwargs": _policy_kwargs_to_json(model.policy_kwargs),
        "observation_space": space_to_json(model.observation_space),
        "action_space": space_to_json(model.action_space),
        "num_timesteps": int(model.num_timesteps),
        "n_updates": int(model._n_updates),
    }
    buffer = io.BytesIO()
    th.save({"policy": model.policy.state_dict(), "optimizer": model.policy.optimizer.state_dict()}, buffer)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("config.json", json.dumps(config, indent=1))
        archive.writestr("weights.pt", buffer.getvalue())


def load_weights(
    path: str | pathlib.Path, env: GymEnv | None = None, device: th.device | str = "auto", load_optimizer: bool = True
) -> "REINFORCE":
    """
    Load a model saved by :func:`save_weights`, unpickling nothing: ``config.json`` is parsed as JSON and
    ``weights.pt`` is read with ``torch.load(weights_only=True)``.

    :param path: The file
    :param env: The environment to train on (its spaces must match the saved ones), or None to only predict
    :param device: Device for the model
    :param load_optimizer: Whether to restore the optimizer's state (Adam moments) as well
    :return: The model
    :raises CorruptModelFileError: if the file is not an intact weights-only file
    :raises UnsafeFileError: if the file names a class, space or value outside the format
    """
    from sb3_reinforce.reinforce import REINFORCE

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
    if not isinstance(config, dict) or config.get("format") != FORMAT or config.get("format_version") != FORMAT_VERSION:
        raise UnsafeFileError(f"{path}: config.json is not a {FORMAT} v{FORMAT_VERSION} description")
    if config.get("policy") not in REINFORCE.policy_aliases:
        raise UnsafeFileError(f"{path}: unknown policy {config.get('policy')!r}, allowed: {sorted(REINFORCE.policy_aliases)}")
    hyperparameters = config.get("hyperparameters")
    if not isinstance(hyperparameters, dict) or set(hyperparameters) - set(_HYPERPARAMETERS):
        raise UnsafeFileError(f"{path}: hyperparameters must be a JSON object with keys among {_HYPERPARAMETERS}")
    observation_space = space_from_json(config["observation_space"])
    action_space = space_from_json(config["action_space"])
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

    model = REINFORCE(
        config["policy"],
        env,  # type: ignore[arg-type]
        learning_rate=float(config["learning_rate"]),
        policy_kwargs=_policy_kwargs_from_json(config.get("policy_kwargs", {})),
        device=device,
        _init_setup_model=False,
        **hyperparameters,
    )
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
    model.num_timesteps = int(config.get("num_timesteps", 0))
    model._n_updates = int(config.get("n_updates", 0))
    return model
