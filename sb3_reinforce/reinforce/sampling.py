"""
The rollout's action sampler: SB3's ``policy.get_distribution(obs).get_actions()``, without ``torch.distributions``.

The actor runs in NumPy on views of its parameters for a plain MLP on a flat ``Box`` (``FlattenExtractor``, ``Linear``,
``Tanh``/``ReLU``), else in torch under ``inference_mode``; the noise comes from torch's global generator (SB3's seed):

- categorical (``Discrete``, ``MultiDiscrete``), logits ``l``: Gumbel-max ``a = argmax_i (l_i - log e_i)``, ``e_i ~ Exp(1)``
- Bernoulli (``MultiBinary``): ``a = 1[u < sigmoid(l)]``, ``u ~ U[0, 1)``
- diagonal Gaussian (``Box``): ``a = mu + exp(log_std) * n``, ``n ~ N(0, 1)`` (clipped by the caller, as in SB3)

Measured 4.5x to 10.6x faster per call than SB3's path (``benchmarks/sampler_cost.py``), the same actions.
"""

from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from scipy.special import expit
from stable_baselines3.common.distributions import (
    BernoulliDistribution,
    CategoricalDistribution,
    DiagGaussianDistribution,
    MultiCategoricalDistribution,
)
from stable_baselines3.common.policies import ActorCriticPolicy, BaseModel
from stable_baselines3.common.preprocessing import is_image_space
from stable_baselines3.common.torch_layers import FlattenExtractor
from stable_baselines3.common.utils import obs_as_tensor
from torch import nn

__all__ = ["FastSampler"]

SUPPORTED_DISTRIBUTIONS = (
    CategoricalDistribution,
    MultiCategoricalDistribution,
    BernoulliDistribution,
    DiagGaussianDistribution,
)


def _relu(x: np.ndarray) -> None:
    np.maximum(x, 0.0, out=x)


def _tanh(x: np.ndarray) -> None:
    np.tanh(x, out=x)


_NUMPY_ACTIVATIONS = {nn.Tanh: _tanh, nn.ReLU: _relu}


class _Noise:
    """Noise from torch's global generator, drawn in place per shape: a NumPy view valid until the next draw of that shape."""

    def __init__(self) -> None:
        self._buffers: dict[tuple[int, ...], tuple[th.Tensor, np.ndarray]] = {}

    def _buffer(self, shape: tuple[int, ...]) -> tuple[th.Tensor, np.ndarray]:
        buffer = self._buffers.get(shape)
        if buffer is None:
            tensor = th.empty(shape, dtype=th.float64)
            buffer = self._buffers[shape] = (tensor, tensor.numpy())
        return buffer

    def exponential(self, shape: tuple[int, ...]) -> np.ndarray:
        tensor, array = self._buffer(shape)
        tensor.exponential_()
        return array

    def uniform(self, shape: tuple[int, ...]) -> np.ndarray:
        tensor, array = self._buffer(shape)
        tensor.uniform_()
        return array

    def normal(self, shape: tuple[int, ...]) -> np.ndarray:
        tensor, array = self._buffer(shape)
        tensor.normal_()
        return array


class FastSampler:
    """
    Samples actions from a :class:`~sb3_reinforce.reinforce.policies.ReinforcePolicy` (see the module docstring).
    Build one per rollout: it reads the parameters in place, but a parameter *replaced* by a new tensor is not seen.

    :param policy: The policy to sample from (without gSDE)
    """

    def __init__(self, policy: ActorCriticPolicy):
        assert isinstance(policy.action_dist, SUPPORTED_DISTRIBUTIONS), "FastSampler does not support this distribution"
        self.policy = policy
        self.action_dist = policy.action_dist
        # Each layer: (W^T, b, activation or None), NumPy views of the parameters; None: run the torch modules
        self.numpy_layers = self._numpy_actor(policy)
        self.noise = _Noise()
        is_gaussian = isinstance(self.action_dist, DiagGaussianDistribution)
        self.log_std = policy.log_std.detach().cpu().numpy() if is_gaussian else None
        if isinstance(self.action_dist, MultiCategoricalDistribution):
            nvec = np.asarray(self.action_dist.action_dims)
            # Column of every flat logit in a (n_dims, max(nvec)) grid: the rest of the grid stays -inf.
            self._grid = (len(nvec), int(nvec.max()))
            self._grid_index = np.concatenate([d * self._grid[1] + np.arange(n) for d, n in enumerate(nvec)])
            self._padded: dict[int, np.ndarray] = {}

    @staticmethod
    def _numpy_actor(policy: ActorCriticPolicy) -> list[tuple[np.ndarray, np.ndarray, Any]] | None:
        """The actor as NumPy layers if it is a plain MLP on flat float observations on the CPU, else None."""
        if (
            policy.device.type != "cpu"
            or not isinstance(policy.observation_space, spaces.Box)
            or (is_image_space(policy.observation_space) and policy.normalize_images)
            or type(policy.pi_features_extractor) is not FlattenExtractor
        ):
            return None
        modules = [*policy.mlp_extractor.policy_net, policy.action_net]
        layers: list[tuple[np.ndarray, np.ndarray, Any]] = []
        for module in modules:
            if isinstance(module, nn.Linear) and type(module) is nn.Linear and module.bias is not None:
                layers.append((module.weight.detach().numpy().T, module.bias.detach().numpy(), None))
            elif type(module) in _NUMPY_ACTIVATIONS and layers and layers[-1][2] is None:
                weight_t, bias, _ = layers[-1]
                layers[-1] = (weight_t, bias, _NUMPY_ACTIVATIONS[type(module)])
            else:
                return None
        return layers if layers[-1][2] is None else None

    def distribution_parameters(self, obs: Any) -> np.ndarray:
        """
        One forward pass of the actor: the logits (categorical, Bernoulli) or the means (Gaussian).

        :param obs: A batch of observations, as the VecEnv returns them
        :return: Array of shape ``(n_envs, n_params)``
        """
        if self.numpy_layers is not None:
            x = np.asarray(obs).reshape(len(obs), -1).astype(np.float32, copy=False)
            for weight_t, bias, activation in self.numpy_layers:
                x = x @ weight_t
                x += bias
                if activation is not None:
                    activation(x)
            return x
        policy = self.policy
        with th.inference_mode():
            features = BaseModel.extract_features(policy, obs_as_tensor(obs, policy.device), policy.pi_features_extractor)
            return policy.action_net(policy.mlp_extractor.forward_actor(features)).cpu().numpy()

    def sample(self, params: np.ndarray) -> np.ndarray:
        """
        Draw one action per row of distribution parameters (see the module docstring for the math).

        :param params: Logits or means, shape ``(n_envs, n_params)``
        :return: Actions with SB3's dtypes: int64 (categorical), float32 (Bernoulli, Gaussian)
        """
        if isinstance(self.action_dist, CategoricalDistribution):
            return np.argmax(params - np.log(self.noise.exponential(params.shape)), axis=1)
        if isinstance(self.action_dist, MultiCategoricalDistribution):
            grid = self._padded.get(len(params))
            if grid is None:
                grid = self._padded[len(params)] = np.full((len(params), *self._grid), -np.inf)
            grid.reshape(len(params), -1)[:, self._grid_index] = params - np.log(self.noise.exponential(params.shape))
            return np.argmax(grid, axis=2)
        if isinstance(self.action_dist, BernoulliDistribution):
            return (self.noise.uniform(params.shape) < expit(params)).astype(np.float32)
        assert self.log_std is not None
        return (params + np.exp(self.log_std) * self.noise.normal(params.shape)).astype(np.float32)

    def __call__(self, obs: Any) -> np.ndarray:
        """
        Sample actions for a batch of observations.

        :param obs: A batch of observations, as the VecEnv returns them
        :return: Actions, shape ``(n_envs, *action_shape)`` (``(n_envs,)`` for ``Discrete``)
        """
        shape: tuple[int, ...] = self.policy.action_space.shape  # type: ignore[assignment]
        return self.sample(self.distribution_parameters(obs)).reshape((-1, *shape))
