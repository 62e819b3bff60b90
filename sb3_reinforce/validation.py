"""Checks of REINFORCE's constructor arguments, run before anything is built or trained."""

import math
from numbers import Integral, Real
from typing import Any

import numpy as np
from gymnasium import spaces

BASELINES = (None, "value", "loo")


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


def validate_hyperparameters(
    learning_rate: Any,
    n_episodes: Any,
    min_steps: Any,
    gamma: Any,
    baseline: Any,
    normalize_returns: Any,
    ent_coef: Any,
    vf_coef: Any,
    max_grad_norm: Any,
    max_rollout_steps: Any,
    n_value_steps: Any = 0,
    value_learning_rate: Any = None,
) -> None:
    """
    Raise a ``ValueError`` naming the first invalid argument and the values it allows.

    Every argument is the one of the same name of :class:`sb3_reinforce.REINFORCE`.
    """
    if not callable(learning_rate):
        check_real("learning_rate", learning_rate, 0.0, allowed="a finite number >= 0 or a schedule (callable)")
    check_int("n_episodes", n_episodes, 1)
    check_int("min_steps", min_steps, 0)
    check_real("gamma", gamma, 0.0, 1.0)
    if baseline not in BASELINES:
        raise ValueError(f"`baseline` must be one of {BASELINES}, got {baseline!r}")
    if not isinstance(normalize_returns, bool):
        raise ValueError(f"`normalize_returns` must be True or False, got {normalize_returns!r}")
    check_real("ent_coef", ent_coef, 0.0, allowed="a finite number >= 0")
    check_real("vf_coef", vf_coef, 0.0, allowed="a finite number >= 0")
    if max_grad_norm is not None:
        check_real("max_grad_norm", max_grad_norm, 0.0, allowed="None (no clipping) or a finite number > 0")
        if max_grad_norm == 0:
            raise ValueError("`max_grad_norm` must be None (no clipping) or a finite number > 0, got 0")
    check_int("max_rollout_steps", max_rollout_steps, 1)
    check_int("n_value_steps", n_value_steps, 0)
    if n_value_steps and baseline != "value":
        raise ValueError(
            f"`n_value_steps` ({n_value_steps}) fits the value baseline: use it with baseline='value', "
            f"got baseline={baseline!r}"
        )
    if value_learning_rate is not None and not callable(value_learning_rate):
        check_real(
            "value_learning_rate",
            value_learning_rate,
            0.0,
            allowed="None (the policy's learning rate), a finite number >= 0 or a schedule (callable)",
        )
    if _is_int(min_steps) and min_steps > max_rollout_steps:
        raise ValueError(f"`min_steps` ({min_steps}) cannot exceed `max_rollout_steps` ({max_rollout_steps})")


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
