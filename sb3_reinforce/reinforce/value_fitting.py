"""
The value baseline ``V(s)``: its steps of its own (REINFORCE's ``n_value_steps > 0``), and the bootstrap of
truncated episodes with it.

After the policy's one step on a batch, ``n_value_steps`` gradient steps regress ``V(s_t)`` on the batch's
returns, ``L_V = mean_t (G_t - V(s_t))^2``, with an optimizer of their own over the value parameters only.
"""

from collections.abc import Callable
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy, BaseModel
from stable_baselines3.common.type_aliases import Schedule
from stable_baselines3.common.utils import update_learning_rate
from torch.nn import functional as F

from sb3_reinforce.reinforce.finite_checks import check_terminal_observation, check_update
from sb3_reinforce.reinforce.policies import ReinforcePolicy

__all__ = ["ValueFitter", "bootstrap_truncated", "value_parameters"]


def value_parameters(policy: ActorCriticPolicy) -> list[th.nn.Parameter]:
    """The parameters that only ``V(s)`` uses: the value layers, and the critic's own features extractor."""
    modules = [policy.mlp_extractor.value_net, policy.value_net]
    if not policy.share_features_extractor:
        modules.append(policy.vf_features_extractor)
    return [param for module in modules for param in module.parameters()]


def _value_predictor(policy: ActorCriticPolicy, observations: Any) -> Callable[[], th.Tensor]:
    """
    ``V(s)`` of the batch, as a function each value step calls. With a features extractor shared with the actor
    (SB3's default), the features do not depend on the value parameters and the value steps do not change them:
    they are computed once, without a graph, and each step runs the critic's layers only. The loss and its
    gradients are those of ``predict_values``; with a CNN, the extractor's forward and backward pass were most
    of the cost of every step. Otherwise (a critic with its own extractor, or a policy that overrides
    ``predict_values``), each step calls ``predict_values``.
    """
    if not policy.share_features_extractor or type(policy).predict_values not in (
        ActorCriticPolicy.predict_values,
        ReinforcePolicy.predict_values,
    ):
        return lambda: policy.predict_values(observations)
    with th.no_grad():
        features = BaseModel.extract_features(policy, observations, policy.vf_features_extractor)
    return lambda: policy.value_net(policy.mlp_extractor.forward_critic(features))


class ValueFitter:
    """
    The value steps of REINFORCE with ``baseline="value"`` and ``n_value_steps > 0``.

    :param policy: The policy whose value head is fitted
    :param n_value_steps: Gradient steps per batch
    :param lr_schedule: The value steps' learning rate, as a function of the progress remaining
    :param max_grad_norm: Clip the value gradients' global norm to this, or None
    """

    def __init__(
        self, policy: ActorCriticPolicy, n_value_steps: int, lr_schedule: Schedule, max_grad_norm: float | None
    ) -> None:
        self.policy = policy
        self.n_value_steps = n_value_steps
        self.lr_schedule = lr_schedule
        self.max_grad_norm = max_grad_norm
        self.optimizer = policy.optimizer_class(  # type: ignore[call-arg]
            value_parameters(policy), lr=lr_schedule(1), **policy.optimizer_kwargs
        )

    def fit(self, observations: Any, returns: th.Tensor, progress_remaining: float, timestep: int) -> th.Tensor:
        """
        ``n_value_steps`` steps on ``L_V`` over the whole batch.

        :param observations: The batch's observations
        :param returns: Their returns ``G_t``
        :param progress_remaining: The training's progress remaining (1 to 0), for the learning-rate schedule
        :param timestep: The model's ``num_timesteps``, for error messages
        :return: The last step's loss
        :raises NonFiniteError: if a loss or gradient is not finite (that step is skipped, the weights unchanged)
        """
        update_learning_rate(self.optimizer, self.lr_schedule(progress_remaining))
        parameters = [p for group in self.optimizer.param_groups for p in group["params"]]
        predict_values = _value_predictor(self.policy, observations)
        for _ in range(self.n_value_steps):
            value_loss = F.mse_loss(predict_values().flatten(), returns)
            self.optimizer.zero_grad()
            value_loss.backward()
            check_update(
                value_loss,
                parameters,
                self.optimizer,
                self.max_grad_norm,
                "value loss",
                "Lower value_learning_rate or scale the rewards (VecNormalize).",
                timestep,
            )
            self.optimizer.step()
        return value_loss.detach()


def bootstrap_truncated(
    policy: ActorCriticPolicy, gamma: float, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]], timestep: int
) -> np.ndarray:
    """
    Add ``gamma * V(s_T)`` to the last reward of every episode a time limit truncated, so that its return estimates
    what the limit cut off (as SB3's A2C/PPO do, GH#633). Only with a value baseline: without one, a truncated
    episode is treated as terminal (no estimate of the future exists).

    :param policy: The policy, with its value head
    :param gamma: The discount factor
    :param rewards: One step's rewards (not modified)
    :param dones: Which environments ended an episode at this step
    :param infos: Their infos (``TimeLimit.truncated``, ``terminal_observation``)
    :param timestep: The model's ``num_timesteps``, for error messages
    :return: The rewards, bootstrapped where an episode was truncated
    """
    if not dones.any():
        return rewards
    rewards = rewards.astype(np.float64)
    for idx in np.flatnonzero(dones):
        if infos[idx].get("TimeLimit.truncated", False) and infos[idx].get("terminal_observation") is not None:
            check_terminal_observation(infos[idx]["terminal_observation"], int(idx), timestep)
            terminal_obs = policy.obs_to_tensor(infos[idx]["terminal_observation"])[0]
            with th.no_grad():
                terminal_value = policy.predict_values(terminal_obs)[0].item()
            rewards[idx] += gamma * terminal_value
    return rewards
