"""Policies for REINFORCE: SB3's ``ActorCriticPolicy`` with an optional value head (without: ``V(s) = b(s) = 0``)."""

import math
from typing import Any

import torch as th
from gymnasium import spaces
from stable_baselines3.common.distributions import CategoricalDistribution, DiagGaussianDistribution
from stable_baselines3.common.policies import ActorCriticPolicy, BaseModel
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, CombinedExtractor, NatureCNN
from stable_baselines3.common.type_aliases import PyTorchObs, Schedule
from torch import nn
from torch.nn import functional as F

from sb3_reinforce.reinforce.sampling import SUPPORTED_DISTRIBUTIONS, FastSampler

__all__ = ["CnnPolicy", "MlpPolicy", "MultiInputPolicy", "ReinforceCnnPolicy", "ReinforceMultiInputPolicy", "ReinforcePolicy"]


def xavier_init_(module: nn.Module) -> None:
    """
    Glorot-uniform initialization of every weight *and bias*, as TF1's ``xavier_initializer`` (a bias of ``n``
    units as an ``(n, 1)`` matrix: ``U(-sqrt(6 / (n + 1)), sqrt(6 / (n + 1)))``).
    """
    for layer in module.modules():
        if isinstance(layer, (nn.Linear, nn.Conv2d)):
            nn.init.xavier_uniform_(layer.weight)
            if layer.bias is not None:
                with th.no_grad():
                    nn.init.xavier_uniform_(layer.bias.view(-1, 1))


def normal_init_(module: nn.Module, std: float, bias: float) -> None:
    """Weights drawn from ``N(0, std**2)``, every bias set to ``bias`` (as TF's ``random_normal_initializer``)."""
    for layer in module.modules():
        if isinstance(layer, (nn.Linear, nn.Conv2d)):
            nn.init.normal_(layer.weight, mean=0.0, std=std)
            if layer.bias is not None:
                nn.init.constant_(layer.bias, bias)


class ReinforcePolicy(ActorCriticPolicy):
    """
    Policy class for REINFORCE (actor, plus a critic used as baseline when ``value_head=True``).

    :param observation_space: Observation space
    :param action_space: Action space
    :param lr_schedule: Learning rate schedule (could be constant)
    :param net_arch: The policy and value networks, as SB3's (default: 64-64, none for ``NatureCNN``). Without a value
        head, a list gives the actor's hidden layers and a dict's ``vf`` is ignored.
    :param value_head: Whether to build a value network ``V(s)``; set by the algorithm from its ``baseline``.
    :param xavier_init: Initialize all weights and biases Glorot-uniform instead of orthogonally (ignores ``ortho_init``)
    :param normal_init: ``(std, bias)``: every weight from ``N(0, std**2)``, every bias ``bias`` (e.g. ``(0.3, 0.1)``),
        instead of orthogonally (ignores ``ortho_init``). None (default): not used. Not with ``xavier_init``.
    :param fast_rollout: Sample the rollout's actions with :class:`~sb3_reinforce.reinforce.sampling.FastSampler`, and
        compute ``log pi(a|s)`` and the entropy in :meth:`evaluate_actions` in closed form (same values as SB3's).
        ``False`` keeps SB3's path; gSDE always does.
    :param kwargs: Passed on to ``ActorCriticPolicy`` (``activation_fn``, ``ortho_init``, ``use_sde``, ``optimizer_kwargs``,
        ...). With Adam (the default), ``optimizer_kwargs`` (default: SB3's ``eps=1e-5``) gets ``foreach=True`` unless
        it sets ``foreach`` (torch's multi-tensor Adam, which torch picks by itself only on GPUs).
    """

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        lr_schedule: Schedule,
        net_arch: list[int] | dict[str, list[int]] | None = None,
        value_head: bool = True,
        xavier_init: bool = False,
        fast_rollout: bool = True,
        normal_init: tuple[float, float] | None = None,
        **kwargs: Any,
    ):
        if normal_init is not None:
            if xavier_init:
                raise ValueError("policy_kwargs: give either xavier_init=True or normal_init=(std, bias), not both")
            try:
                valid = len(normal_init) == 2 and all(math.isfinite(v) for v in normal_init) and normal_init[0] > 0
            except TypeError:  # not a pair of numbers
                valid = False
            if not valid:
                raise ValueError(f"policy_kwargs normal_init must be (std, bias), std > 0, both finite; got {normal_init!r}")
            normal_init = (float(normal_init[0]), float(normal_init[1]))
        self.value_head = value_head
        self.xavier_init = xavier_init
        self.normal_init = normal_init
        self.fast_rollout = fast_rollout
        if not value_head:
            # A separate critic feature extractor would never be used.
            kwargs["share_features_extractor"] = True
        if kwargs.get("optimizer_class", th.optim.Adam) is th.optim.Adam:
            optimizer_kwargs = kwargs.get("optimizer_kwargs")
            kwargs["optimizer_kwargs"] = {"foreach": True, **({"eps": 1e-5} if optimizer_kwargs is None else optimizer_kwargs)}
        super().__init__(observation_space, action_space, lr_schedule, net_arch=net_arch, **kwargs)

    def _build_mlp_extractor(self) -> None:
        if not self.value_head:
            # Actor only: SB3's __init__ already set its default ``net_arch`` and converted the old ``[dict(pi=, vf=)]``.
            net_arch = self.net_arch
            pi_arch = net_arch.get("pi", []) if isinstance(net_arch, dict) else list(net_arch)
            self.net_arch = dict(pi=pi_arch, vf=[])
        super()._build_mlp_extractor()

    def _build(self, lr_schedule: Schedule) -> None:
        super()._build(lr_schedule)
        if not self.value_head:
            del self.value_net
        if self.xavier_init:
            xavier_init_(self)
        if self.normal_init is not None:
            normal_init_(self, *self.normal_init)
        if not self.value_head or self.xavier_init or self.normal_init is not None:
            # Parameters changed after SB3 created the optimizer: create it again.
            self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)  # type: ignore[call-arg]

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(value_head=self.value_head, xavier_init=self.xavier_init, fast_rollout=self.fast_rollout)
        if self.normal_init is not None:
            data.update(normal_init=self.normal_init)
        if not self.value_head:
            data.pop("share_features_extractor", None)
        return data

    def fast_sampler(self) -> FastSampler | None:
        """
        A :class:`~sb3_reinforce.reinforce.sampling.FastSampler` for the current parameters, or None where the rollout
        must use SB3's ``get_distribution(obs).get_actions()`` (``fast_rollout=False``, gSDE, other distributions,
        subclasses that build their own).
        """
        if not self._has_standard_distribution() or not isinstance(self.action_dist, SUPPORTED_DISTRIBUTIONS):
            return None
        return FastSampler(self)

    def extract_actor_features(self, obs: PyTorchObs) -> th.Tensor:
        """
        The actor's features (``pi_features_extractor`` only), as SB3's ``get_distribution`` computes them.

        :param obs: Observation
        :return: The actor's features
        """
        return BaseModel.extract_features(self, obs, self.pi_features_extractor)

    def _has_standard_distribution(self) -> bool:
        """Whether the fast paths may be used: on, no gSDE, and the distribution built as SB3 builds it."""
        builds_own_distribution = (
            type(self).get_distribution is not ActorCriticPolicy.get_distribution
            or type(self)._get_action_dist_from_latent is not ActorCriticPolicy._get_action_dist_from_latent
        )
        return self.fast_rollout and not self.use_sde and not builds_own_distribution

    def _log_prob_and_entropy(self, latent_pi: th.Tensor, actions: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """``log pi(a|s)`` and ``H(pi(.|s))`` from the actor's latent: closed forms (categorical, Gaussian) or SB3's."""
        params = self.action_net(latent_pi)
        if isinstance(self.action_dist, CategoricalDistribution):
            # log pi(a|s) = l_a - logsumexp(l),   H = -sum_i pi_i log pi_i   (logits l)
            log_pi = F.log_softmax(params, dim=-1).clamp(min=th.finfo(params.dtype).min)
            log_prob = log_pi.gather(-1, actions.long().reshape(-1, 1)).squeeze(-1)
            return log_prob, -(log_pi.exp() * log_pi).sum(-1)
        if isinstance(self.action_dist, DiagGaussianDistribution):
            # log N(a; mu, sigma) = sum_j [ -(a_j - mu_j)^2 / (2 sigma_j^2) - log sigma_j - log sqrt(2 pi) ]
            # H = sum_j [ 1/2 + log sqrt(2 pi) + log sigma_j ]
            log_std = self.log_std.expand_as(params)
            z = (actions.reshape(params.shape) - params) * th.exp(-log_std)
            log_prob = (-0.5 * z.pow(2) - log_std - math.log(math.sqrt(2 * math.pi))).sum(-1)
            return log_prob, (0.5 + math.log(math.sqrt(2 * math.pi)) + log_std).sum(-1)
        distribution = self._get_action_dist_from_latent(latent_pi)
        return distribution.log_prob(actions), distribution.entropy()  # type: ignore[return-value]

    def _zero_values(self, like: th.Tensor) -> th.Tensor:
        return th.zeros((like.shape[0], 1), device=like.device, dtype=th.float32)

    def forward(self, obs: th.Tensor, deterministic: bool = False) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """
        Forward pass in the actor (and the critic, if there is one).

        :param obs: Observation
        :param deterministic: Whether to sample or use deterministic actions
        :return: action, value (zeros without a value head: the baseline b(s) = 0) and log probability
        """
        if self.value_head:
            return super().forward(obs, deterministic)
        distribution = self.get_distribution(obs)
        actions = distribution.get_actions(deterministic=deterministic)
        log_prob = distribution.log_prob(actions)
        actions = actions.reshape((-1, *self.action_space.shape))  # type: ignore[misc]
        return actions, self._zero_values(log_prob), log_prob

    def evaluate_actions(self, obs: PyTorchObs, actions: th.Tensor) -> tuple[th.Tensor, th.Tensor, th.Tensor | None]:
        """
        Evaluate actions according to the current policy, given the observations.

        :param obs: Observation
        :param actions: Actions
        :return: estimated value (zeros without a value head), log likelihood of the actions, entropy
        """
        if not self._has_standard_distribution():
            if self.value_head:
                return super().evaluate_actions(obs, actions)
            distribution = self.get_distribution(obs)
            log_prob = distribution.log_prob(actions)
            return self._zero_values(log_prob), log_prob, distribution.entropy()
        # SB3's evaluate_actions, with the closed forms in place of the distribution object
        features = self.extract_features(obs)
        values = None
        if not self.value_head:
            latent_pi = self.mlp_extractor.forward_actor(features)  # type: ignore[arg-type]
        elif self.share_features_extractor:
            latent_pi, latent_vf = self.mlp_extractor(features)
            values = self.value_net(latent_vf)
        else:
            pi_features, vf_features = features
            latent_pi = self.mlp_extractor.forward_actor(pi_features)
            values = self.value_net(self.mlp_extractor.forward_critic(vf_features))
        log_prob, entropy = self._log_prob_and_entropy(latent_pi, actions)
        return (self._zero_values(log_prob) if values is None else values), log_prob, entropy

    def predict_values(self, obs: PyTorchObs) -> th.Tensor:
        """
        Get the estimated values given the observations.

        :param obs: Observation
        :return: V(s), or zeros (the baseline of plain REINFORCE) when there is no value head
        """
        if self.value_head:
            return super().predict_values(obs)
        return self._zero_values(next(iter(obs.values())) if isinstance(obs, dict) else obs)


class ReinforceCnnPolicy(ReinforcePolicy):
    """CNN policy for REINFORCE (``NatureCNN`` features), see :class:`ReinforcePolicy` for the parameters."""

    def __init__(self, *args: Any, features_extractor_class: type[BaseFeaturesExtractor] = NatureCNN, **kwargs: Any):
        super().__init__(*args, features_extractor_class=features_extractor_class, **kwargs)


class ReinforceMultiInputPolicy(ReinforcePolicy):
    """Policy for ``Dict`` observation spaces (``CombinedExtractor`` features), see :class:`ReinforcePolicy`."""

    def __init__(self, *args: Any, features_extractor_class: type[BaseFeaturesExtractor] = CombinedExtractor, **kwargs: Any):
        super().__init__(*args, features_extractor_class=features_extractor_class, **kwargs)


MlpPolicy = ReinforcePolicy
CnnPolicy = ReinforceCnnPolicy
MultiInputPolicy = ReinforceMultiInputPolicy
