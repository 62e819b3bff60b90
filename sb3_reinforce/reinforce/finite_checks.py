"""
Numerical guards: a NaN or an inf from the environment, or in a loss or gradient, stops training with an error
that says where it came from, before it reaches the weights.

The checks run once per environment step (a sum per array on the fast path) and once per gradient step.
"""

from collections.abc import Iterable
from typing import Any

import numpy as np
import torch as th

__all__ = ["NonFiniteError", "check_step", "check_terminal_observation", "check_update", "total_grad_norm"]


class NonFiniteError(FloatingPointError):
    """An environment returned a NaN/inf reward or observation, or the loss/gradient became non-finite."""


def _non_finite_parts(obs: Any) -> list[tuple[str | None, np.ndarray]]:
    """The floating-point parts of an observation (an array, or a dict of arrays) that hold a NaN or an inf."""
    parts = obs.items() if isinstance(obs, dict) else [(None, obs)]
    arrays = [(key, np.asarray(value)) for key, value in parts]
    return [(key, a) for key, a in arrays if np.issubdtype(a.dtype, np.floating) and not np.isfinite(a).all()]


def _raise_for_observation(
    what: str, env_idx: int, key: str | None, value: np.ndarray, timestep: int, consequence: str
) -> None:
    where = f" (key {key!r})" if key is not None else ""
    raise NonFiniteError(
        f"Environment {env_idx} returned a non-finite {what}{where} at timestep {timestep}: {value}. "
        f"{consequence} (check the environment, or use VecCheckNan to find the cause)."
    )


def check_step(new_obs: Any, rewards: np.ndarray, timestep: int) -> None:
    """
    Check one step of a VecEnv: every reward and every floating-point observation must be finite.

    :param new_obs: The observations ``env.step`` returned (an array, or a dict of arrays)
    :param rewards: The rewards it returned
    :param timestep: The model's ``num_timesteps``, for the message
    :raises NonFiniteError: naming the environment, the value and the timestep
    """
    # Fast path: a NaN/inf anywhere makes a sum non-finite (a sum that overflows only sends us on to the exact
    # checks below, which then find nothing).
    parts = new_obs.values() if isinstance(new_obs, dict) else (new_obs,)
    if np.isfinite(rewards.sum()) and all(
        isinstance(part, np.ndarray) and (part.dtype.kind != "f" or np.isfinite(part.sum())) for part in parts
    ):
        return
    if not np.isfinite(rewards).all():
        env_idx = int(np.flatnonzero(~np.isfinite(rewards))[0])
        raise NonFiniteError(
            f"Environment {env_idx} returned a non-finite reward ({rewards[env_idx]}) at timestep {timestep}: "
            "REINFORCE cannot learn from it (check the environment's reward, or wrap it to clip rewards)."
        )
    for key, obs in _non_finite_parts(new_obs):
        env_idx = int(np.flatnonzero(~np.isfinite(obs.reshape(len(obs), -1)).all(axis=1))[0])
        _raise_for_observation("observation", env_idx, key, obs[env_idx], timestep, "REINFORCE cannot learn from it")


def check_terminal_observation(terminal_obs: Any, env_idx: int, timestep: int) -> None:
    """
    Check the terminal observation of a truncated episode, which only the value bootstrap reads.

    :param terminal_obs: ``infos[env_idx]["terminal_observation"]``
    :param env_idx: The environment's index
    :param timestep: The model's ``num_timesteps``, for the message
    :raises NonFiniteError: naming the environment and the value
    """
    for key, obs in _non_finite_parts(terminal_obs):
        _raise_for_observation(
            "terminal observation", env_idx, key, obs, timestep, "REINFORCE cannot bootstrap the truncated episode from it"
        )


def total_grad_norm(parameters: Iterable[th.Tensor]) -> th.Tensor:
    """The global 2-norm of the parameters' gradients, as ``clip_grad_norm_`` computes it, without clipping."""
    parameters = list(parameters)
    if hasattr(th.nn.utils, "get_total_norm"):  # torch >= 2.6
        return th.nn.utils.get_total_norm([p.grad for p in parameters if p.grad is not None])
    return th.nn.utils.clip_grad_norm_(parameters, float("inf"))  # older torch: the same norm (a x1 rescale)


def check_update(
    loss: th.Tensor,
    parameters: list[th.Tensor],
    optimizer: th.optim.Optimizer,
    max_grad_norm: float | None,
    what: str,
    advice: str,
    timestep: int,
) -> th.Tensor:
    """
    Clip the gradients (``max_grad_norm``) or only measure their norm, and refuse a non-finite loss or norm:
    the gradients are zeroed and ``optimizer.step()`` must not run, so the weights stay as they were.

    :param loss: The loss whose gradients were just computed
    :param parameters: The parameters the optimizer steps
    :param optimizer: That optimizer
    :param max_grad_norm: Clip the global norm to this, or None to measure it only
    :param what: What was being updated, for the message (``"loss"``, ``"value loss"``)
    :param advice: What the user can do, for the message
    :param timestep: The model's ``num_timesteps``, for the message
    :return: The gradients' global norm before clipping
    :raises NonFiniteError: if the loss or the norm is not finite
    """
    if max_grad_norm is not None:
        grad_norm = th.nn.utils.clip_grad_norm_(parameters, max_grad_norm)
    else:  # the norm only (logged, and checked below): no clipping, so no rescaling of every gradient
        grad_norm = total_grad_norm(parameters)
    if not (th.isfinite(loss) and th.isfinite(grad_norm)):
        optimizer.zero_grad()
        raise NonFiniteError(
            f"Non-finite {what} ({loss.item()}) or gradient norm ({grad_norm.item()}) at timestep {timestep}: "
            f"the update was skipped and the weights are unchanged. {advice}"
        )
    return grad_norm
