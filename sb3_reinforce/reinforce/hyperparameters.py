"""
REINFORCE's hyperparameters: the one table of them (derived from the constructor's signature) and their checks,
run before anything is built or trained.
"""

import inspect
import math
import os
from collections.abc import Callable, Mapping
from numbers import Integral, Real
from typing import Any

import numpy as np
from gymnasium import spaces

__all__ = ["BASELINES", "CHECKS", "NOT_HYPERPARAMETERS", "check_spaces", "hyperparameter_defaults", "validate_hyperparameters"]

BASELINES = (None, "value", "loo")
#: Constructor arguments that are not hyperparameters: the policy and the environment (what is learned, from
#: what), the device, and SB3's switch to build the networks later.
NOT_HYPERPARAMETERS = frozenset({"policy", "env", "device", "_init_setup_model"})


def _is_int(value: Any) -> bool:
    return isinstance(value, Integral) and not isinstance(value, bool)


def _is_real(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(float(value))


def check_int(name: str, value: Any, minimum: int) -> None:
    if not _is_int(value) or value < minimum:
        raise ValueError(f"`{name}` must be an integer >= {minimum}, got {value!r}")


def check_real(name: str, value: Any, low: float, high: float = math.inf, allowed: str | None = None) -> None:
    if not _is_real(value) or not low <= float(value) <= high:
        raise ValueError(f"`{name}` must be {allowed or f'a finite number in [{low}, {high}]'}, got {value!r}")


def hyperparameter_defaults(algorithm: type) -> dict[str, Any]:
    """
    The one table of an algorithm's hyperparameters: every argument of its constructor but what it learns
    from, where it runs and SB3's build switch (``NOT_HYPERPARAMETERS``), with its default.

    Validation, the weights-only format (:mod:`sb3_reinforce.reinforce.weights_only`) and the zoo's search space
    read it, so an argument added to the constructor is known to all three at once.

    :param algorithm: The algorithm class (:class:`~sb3_reinforce.REINFORCE`)
    :return: ``{name: default}`` in the constructor's order
    """
    parameters = inspect.signature(algorithm).parameters  # the constructor's, less self
    return {name: p.default for name, p in parameters.items() if name not in NOT_HYPERPARAMETERS}


def validate_hyperparameters(values: Mapping[str, Any]) -> None:
    """
    Raise a ``ValueError`` naming the first invalid argument and the values it allows.

    :param values: REINFORCE's hyperparameters by name (its constructor's arguments of the same names; those
        missing are not checked)
    """
    unknown = sorted(set(values) - set(CHECKS))
    if unknown:
        raise ValueError(f"Unknown REINFORCE hyperparameters {unknown}: the allowed names are {sorted(CHECKS)}")
    for name, value in values.items():
        CHECKS[name](name, value)
    n_value_steps = values.get("n_value_steps", 0)
    if n_value_steps and values.get("baseline") != "value":
        raise ValueError(
            f"`n_value_steps` ({n_value_steps}) fits the value baseline: use it with baseline='value', "
            f"got baseline={values.get('baseline')!r}"
        )
    min_steps, max_rollout_steps = values.get("min_steps", 0), values.get("max_rollout_steps", 1)
    if _is_int(min_steps) and _is_int(max_rollout_steps) and min_steps > max_rollout_steps:
        raise ValueError(f"`min_steps` ({min_steps}) cannot exceed `max_rollout_steps` ({max_rollout_steps})")


def _learning_rate(name: str, value: Any) -> None:
    if not callable(value):
        check_real(name, value, 0.0, allowed="a finite number >= 0 or a schedule (callable)")


def _optional_learning_rate(name: str, value: Any) -> None:
    if value is not None and not callable(value):
        check_real(
            name, value, 0.0, allowed="None (the policy's learning rate), a finite number >= 0 or a schedule (callable)"
        )


def _baseline(name: str, value: Any) -> None:
    if value not in BASELINES:
        raise ValueError(f"`{name}` must be one of {BASELINES}, got {value!r}")


def _bool(name: str, value: Any) -> None:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"`{name}` must be True or False, got {value!r}")


def _max_grad_norm(name: str, value: Any) -> None:
    if value is not None and (not _is_real(value) or float(value) <= 0):
        raise ValueError(f"`{name}` must be None (no clipping) or a finite number > 0, got {value!r}")


def _optional_int(minimum: int) -> Callable[[str, Any], None]:
    def check(name: str, value: Any) -> None:
        if value is not None:
            check_int(name, value, minimum)

    return check


def _optional_dict(name: str, value: Any) -> None:
    if value is not None and not isinstance(value, dict):
        raise ValueError(f"`{name}` must be None or a dict of keyword arguments, got {value!r}")


def _optional_str(name: str, value: Any) -> None:
    if value is not None and not isinstance(value, (str, os.PathLike)):
        raise ValueError(f"`{name}` must be None or a path, got {value!r}")


def _anything(name: str, value: Any) -> None:
    """Checked where it is used (``rollout_buffer_class`` when the buffer is built)."""


#: The check of each hyperparameter (a test holds its keys equal to :func:`hyperparameter_defaults`' table).
CHECKS: dict[str, Callable[[str, Any], None]] = {
    "learning_rate": _learning_rate,
    "n_episodes": lambda name, value: check_int(name, value, 1),
    "min_steps": lambda name, value: check_int(name, value, 0),
    "gamma": lambda name, value: check_real(name, value, 0.0, 1.0),
    "baseline": _baseline,
    "normalize_returns": _bool,
    "ent_coef": lambda name, value: check_real(name, value, 0.0, allowed="a finite number >= 0"),
    "vf_coef": lambda name, value: check_real(name, value, 0.0, allowed="a finite number >= 0"),
    "n_value_steps": lambda name, value: check_int(name, value, 0),
    "value_learning_rate": _optional_learning_rate,
    "max_grad_norm": _max_grad_norm,
    "use_sde": _bool,
    "sde_sample_freq": lambda name, value: check_int(name, value, -1),
    "max_rollout_steps": lambda name, value: check_int(name, value, 1),
    "rollout_buffer_class": _anything,
    "rollout_buffer_kwargs": _optional_dict,
    "stats_window_size": lambda name, value: check_int(name, value, 1),
    "tensorboard_log": _optional_str,
    "policy_kwargs": _optional_dict,
    "verbose": lambda name, value: check_int(name, value, 0),
    "seed": _optional_int(0),
}


def check_spaces(observation_space: spaces.Space, action_space: spaces.Space) -> None:
    """
    Refuse ``Discrete``/``MultiDiscrete`` spaces whose ``start`` is not 0: SB3's preprocessing and action
    distributions assume values from 0, so such spaces would fail deep inside torch (observations) or
    silently send the environment actions outside its space (actions).

    :param observation_space: The observation space (``Dict`` spaces are checked key by key)
    :param action_space: The action space
    :raises ValueError: naming the space
    """
    named = [("action space", action_space)]
    if isinstance(observation_space, spaces.Dict):
        named += [(f"observation space[{key!r}]", sub) for key, sub in observation_space.spaces.items()]
    else:
        named.append(("observation space", observation_space))
    for name, space in named:
        if isinstance(space, (spaces.Discrete, spaces.MultiDiscrete)) and np.any(np.asarray(space.start) != 0):
            raise ValueError(
                f"The {name} {space} has start={space.start}: SB3 policies only support Discrete/MultiDiscrete spaces "
                "starting at 0. Shift it with a wrapper (e.g. gymnasium.wrappers.TransformObservation / TransformAction)."
            )
