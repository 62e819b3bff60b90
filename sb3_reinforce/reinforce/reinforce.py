import inspect
import math
import os
import warnings
from collections.abc import Callable, Mapping
from numbers import Integral, Real
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.policies import ActorCriticPolicy, BaseModel, BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import FloatSchedule, explained_variance, obs_as_tensor, update_learning_rate
from stable_baselines3.common.vec_env import VecEnv
from torch.nn import functional as F

from sb3_reinforce.reinforce.buffers import DictEpisodeRolloutBuffer, EpisodeRolloutBuffer
from sb3_reinforce.reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy, ReinforcePolicy
from sb3_reinforce.reinforce.returns import leave_one_out_baseline, normalize_returns

SelfREINFORCE = TypeVar("SelfREINFORCE", bound="REINFORCE")

BASELINES = (None, "value", "loo")
#: Constructor arguments that are not hyperparameters: what is learned, from what, where, and SB3's build switch.
NOT_HYPERPARAMETERS = frozenset({"policy", "env", "device", "_init_setup_model"})


class REINFORCE(OnPolicyAlgorithm):
    """
    REINFORCE: Monte-Carlo policy gradient (Williams, 1992), optionally with a baseline.

    Paper: https://link.springer.com/article/10.1007/BF00992696
    Introduction: https://spinningup.openai.com/en/latest/spinningup/rl_intro3.html

    The policy plays whole episodes, then takes one gradient step on ``mean_t(-log pi(a_t|s_t) * A_t)``, where
    ``A_t`` is the discounted reward-to-go ``G_t`` (standardized over the batch by default), or ``G_t - b_t`` with a
    baseline (see ``baseline``). Truncated episodes are bootstrapped with ``gamma * V(s_T)`` with a value baseline,
    else treated as terminal. A non-finite loss or gradient raises ``FloatingPointError``, leaving the weights unchanged.

    :param policy: The policy model to use (MlpPolicy, CnnPolicy, MultiInputPolicy, or a class)
    :param env: The environment to learn from (if registered in Gym, can be str)
    :param learning_rate: The learning rate, it can be a function of the current progress remaining (from 1 to 0)
    :param n_episodes: Finished episodes per environment per gradient step (counted as SB3's ``n_steps``): a batch
        holds at least ``n_episodes * n_envs`` episodes (more if several end at the same step)
    :param min_steps: Minimum number of environment steps per batch as well, all environments together
    :param gamma: Discount factor, in [0, 1]
    :param baseline: ``None`` for plain REINFORCE (no value network is built), ``"value"`` for a learned ``V(s)``
        regressed on the returns, or ``"loo"`` for the leave-one-out mean of the batch's other episodes
        (:func:`~sb3_reinforce.reinforce.returns.leave_one_out_baseline`; needs ``n_episodes * n_envs >= 2``)
    :param normalize_returns: Standardize the policy-gradient weights (returns, or advantages) over the batch;
        equal returns give zero weights, never NaN
    :param ent_coef: Entropy coefficient for the loss calculation
    :param vf_coef: Value function coefficient for the loss calculation (``baseline="value"``, ``n_value_steps=0``)
    :param n_value_steps: Gradient steps fitting the value baseline to each batch's returns after the policy's step,
        with an optimizer of their own (value layers only with a shared features extractor). 0 (default): one joint
        step on ``policy_loss + vf_coef * value_loss``, as A2C. ``baseline="value"`` only.
    :param value_learning_rate: Learning rate (number or schedule) of the value steps; None (default): ``learning_rate``
    :param max_grad_norm: The maximum value for the gradient clipping, or None (default) for no clipping (with
        ``baseline="value"``, the critic's early gradient dominates a global norm, and A2C/PPO's 0.5 starves the actor)
    :param use_sde: Whether to use generalized State Dependent Exploration (gSDE) instead of action noise (default: False)
    :param sde_sample_freq: Sample a new noise matrix every n steps with gSDE (-1, default: only at the rollout's start)
    :param max_rollout_steps: Most transitions the rollout buffer may hold (all environments together): beyond,
        ``RolloutLimitError`` is raised instead of exhausting memory
    :param rollout_buffer_class: An :class:`~sb3_reinforce.reinforce.buffers.EpisodeRolloutBuffer` (sub)class (SB3's
        fixed-length ``RolloutBuffer`` cannot hold whole episodes). If ``None``, it will be automatically selected.
    :param rollout_buffer_kwargs: Keyword arguments to pass to the rollout buffer on creation.
    :param stats_window_size: Number of episodes the rollout logging averages success rate, episode length and reward over
    :param tensorboard_log: the log location for tensorboard (if None, no logging)
    :param policy_kwargs: arguments passed to the policy, see :class:`~sb3_reinforce.reinforce.policies.ReinforcePolicy`
    :param verbose: Verbosity level: 0 for no output, 1 for info messages (device, wrappers, ...), 2 for debug messages
    :param seed: Seed for the pseudo random generators
    :param device: Device (cpu, cuda, ...) on which the code should be run; auto: the GPU if possible
    :param _init_setup_model: Whether or not to build the network at the creation of the instance
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {
        "MlpPolicy": MlpPolicy,
        "CnnPolicy": CnnPolicy,
        "MultiInputPolicy": MultiInputPolicy,
    }
    rollout_buffer: EpisodeRolloutBuffer  # type: ignore[assignment]

    def __init__(
        self,
        policy: str | type[ReinforcePolicy],
        env: GymEnv | str,
        learning_rate: float | Schedule = 1e-3,
        n_episodes: int = 1,
        min_steps: int = 0,
        gamma: float = 0.99,
        baseline: str | None = None,
        normalize_returns: bool = True,
        ent_coef: float = 0.0,
        vf_coef: float = 0.5,
        n_value_steps: int = 0,
        value_learning_rate: float | Schedule | None = None,
        max_grad_norm: float | None = None,
        use_sde: bool = False,
        sde_sample_freq: int = -1,
        max_rollout_steps: int = 1_000_000,
        rollout_buffer_class: type[EpisodeRolloutBuffer] | None = None,
        rollout_buffer_kwargs: dict[str, Any] | None = None,
        stats_window_size: int = 100,
        tensorboard_log: str | None = None,
        policy_kwargs: dict[str, Any] | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ):
        arguments = locals()  # every hyperparameter is checked before anything is built
        check_hyperparameters({name: arguments[name] for name in ALLOWED_VALUES})  # keys: the signature (tested)
        if policy_kwargs is not None and "value_head" in policy_kwargs:
            raise ValueError("Do not set `value_head` in policy_kwargs: use REINFORCE(baseline='value') or baseline=None")
        super().__init__(
            policy,
            env,
            learning_rate=learning_rate,
            n_steps=1,  # unused: REINFORCE's rollouts end on episode boundaries (n_episodes, min_steps)
            gamma=gamma,
            gae_lambda=1.0,  # Monte-Carlo returns
            ent_coef=ent_coef,
            vf_coef=vf_coef,
            max_grad_norm=max_grad_norm,  # type: ignore[arg-type]
            use_sde=use_sde,
            sde_sample_freq=sde_sample_freq,
            rollout_buffer_class=rollout_buffer_class,  # type: ignore[arg-type]
            rollout_buffer_kwargs=rollout_buffer_kwargs,
            stats_window_size=stats_window_size,
            tensorboard_log=tensorboard_log,
            policy_kwargs=policy_kwargs,
            verbose=verbose,
            device=device,
            seed=seed,
            _init_setup_model=False,
            supported_action_spaces=(spaces.Box, spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary),
        )
        self.n_episodes = n_episodes
        self.min_steps = min_steps
        self.baseline = baseline
        self.normalize_returns = normalize_returns
        self.n_value_steps = n_value_steps
        self.value_learning_rate = value_learning_rate
        self.max_rollout_steps = max_rollout_steps

        if _init_setup_model:
            self._check_batch_for_baseline()
            self._setup_model()

    #: A running episode this long, as a share of ``max_rollout_steps`` per environment, is warned about.
    long_episode_share: ClassVar[float] = 0.1

    def _check_batch_for_baseline(self) -> None:
        """Refuse a leave-one-out baseline whose batch would hold one episode: checked when the model is built for
        training and when it starts to learn, not on ``load``, so that a model trained on several environments can
        act (``predict``, ``evaluate_policy``, the zoo's ``enjoy``) on one."""
        if self.baseline == "loo" and self.n_episodes * self.n_envs < 2:
            raise ValueError(
                f"baseline='loo' compares each episode with the other episodes of its batch, but a batch holds "
                f"n_episodes * n_envs = {self.n_episodes} * {self.n_envs} = 1 episode: set n_episodes >= 2 or n_envs >= 2"
            )

    def _setup_model(self) -> None:
        _check_spaces(self.observation_space, self.action_space)
        self._setup_lr_schedule()
        self.set_random_seed(self.seed)

        if self.rollout_buffer_class is None:
            is_dict = isinstance(self.observation_space, spaces.Dict)
            self.rollout_buffer_class = DictEpisodeRolloutBuffer if is_dict else EpisodeRolloutBuffer  # type: ignore[assignment]
        buffer_class: type[EpisodeRolloutBuffer] = self.rollout_buffer_class  # type: ignore[assignment]
        if not (isinstance(buffer_class, type) and issubclass(buffer_class, EpisodeRolloutBuffer)):
            raise TypeError(
                f"rollout_buffer_class must be an EpisodeRolloutBuffer (or a subclass), not {buffer_class!r}: REINFORCE "
                "learns from whole episodes, which SB3's fixed-length RolloutBuffer cannot hold"
            )
        buffer_kwargs = dict(self.rollout_buffer_kwargs)
        self.rollout_buffer = buffer_class(
            buffer_kwargs.pop("buffer_size", 256),
            self.observation_space,
            self.action_space,
            device=self.device,
            gamma=self.gamma,
            n_envs=self.n_envs,
            n_episodes=self.n_episodes * self.n_envs,  # per environment, as SB3's n_steps
            min_steps=self.min_steps,
            max_steps=self.max_rollout_steps,
            **buffer_kwargs,
        )
        policy_kwargs = dict(self.policy_kwargs)
        if issubclass(self.policy_class, ReinforcePolicy):
            policy_kwargs["value_head"] = self.baseline == "value"
        self.policy = self.policy_class(  # type: ignore[assignment]
            self.observation_space, self.action_space, self.lr_schedule, use_sde=self.use_sde, **policy_kwargs
        )
        self.policy = self.policy.to(self.device)
        self._maybe_recommend_cpu("ReinforcePolicy")
        # The value steps' optimizer (n_value_steps > 0), over the parameters only V(s) uses; SB3 saves it by name.
        self.value_optimizer: th.optim.Optimizer | None = None
        if self.n_value_steps > 0:
            value_lr = self.learning_rate if self.value_learning_rate is None else self.value_learning_rate
            self.value_lr_schedule = FloatSchedule(value_lr)
            modules = [self.policy.mlp_extractor.value_net, self.policy.value_net]
            if not self.policy.share_features_extractor:
                modules.append(self.policy.vf_features_extractor)
            self.value_optimizer = self.policy.optimizer_class(  # type: ignore[call-arg]
                [p for module in modules for p in module.parameters()],
                lr=self.value_lr_schedule(1),
                **self.policy.optimizer_kwargs,
            )

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        state_dicts, variables = super()._get_torch_save_params()
        if self.value_optimizer is not None:
            state_dicts = [*state_dicts, "value_optimizer"]
        return state_dicts, variables

    def _setup_learn(
        self,
        total_timesteps: int,
        callback: MaybeCallback = None,
        reset_num_timesteps: bool = True,
        tb_log_name: str = "run",
        progress_bar: bool = False,
    ) -> tuple[int, BaseCallback]:
        self._check_batch_for_baseline()  # load may have given fewer envs, or n_episodes changed since construction
        env_will_reset = reset_num_timesteps or self._last_obs is None
        result = super()._setup_learn(total_timesteps, callback, reset_num_timesteps, tb_log_name, progress_bar)
        if env_will_reset:
            # Running episodes belong to the environment state that the reset discards.
            self.rollout_buffer.reset()
        return result

    def _update_current_progress_remaining(self, num_timesteps: int, total_timesteps: int) -> None:
        # The last batch runs past total_timesteps: floor at 0, else a linear learning rate goes negative (ascent).
        super()._update_current_progress_remaining(num_timesteps, total_timesteps)
        self._current_progress_remaining = max(0.0, self._current_progress_remaining)

    def collect_rollouts(
        self,
        env: VecEnv,
        callback: BaseCallback,
        rollout_buffer: RolloutBuffer,
        n_rollout_steps: int,
    ) -> bool:
        """
        Play the current policy until the buffer holds a batch of whole episodes, then compute their returns.

        A callback that stops training loses no transition: each is stored before ``callback.on_step()``.

        :param env: The training environment
        :param callback: Callback that will be called at each step (and at the beginning and end of the rollout)
        :param rollout_buffer: An :class:`EpisodeRolloutBuffer`
        :param n_rollout_steps: Unused: the rollout length is set by ``n_episodes`` and ``min_steps``
        :return: True if the batch is complete, False if a callback stopped training first.
        """
        assert self._last_obs is not None, "No previous observation was provided"
        assert isinstance(rollout_buffer, EpisodeRolloutBuffer), "REINFORCE needs an EpisodeRolloutBuffer"
        # Switch to eval mode (this affects batch norm / dropout)
        self.policy.set_training_mode(False)
        n_steps = 0
        if self.use_sde:
            self.policy.reset_noise(env.num_envs)

        # Only the actor runs here: log pi(a|s) (and V(s)) are evaluated with gradients in train().
        sampler = self.policy.fast_sampler() if isinstance(self.policy, ReinforcePolicy) else None

        callback.on_rollout_start()
        long_episode = max(1, int(self.long_episode_share * rollout_buffer.max_rows))
        check_at = long_episode

        while not rollout_buffer.is_full:
            if self.use_sde and self.sde_sample_freq > 0 and n_steps % self.sde_sample_freq == 0:
                self.policy.reset_noise(env.num_envs)

            if sampler is not None:
                actions = sampler(self._last_obs)
            else:
                with th.no_grad():
                    obs_tensor = obs_as_tensor(self._last_obs, self.device)
                    actions = self.policy.get_distribution(obs_tensor).get_actions().cpu().numpy()
                actions = actions.reshape((-1, *self.action_space.shape))

            clipped_actions = actions
            if isinstance(self.action_space, spaces.Box):
                if self.policy.squash_output:
                    clipped_actions = self.policy.unscale_action(clipped_actions)
                else:
                    # Clip to the bounds: the Gaussian is unbounded. The unclipped action is stored and trained on.
                    clipped_actions = np.clip(actions, self.action_space.low, self.action_space.high)

            new_obs, rewards, dones, infos = env.step(clipped_actions)
            self.num_timesteps += env.num_envs
            n_steps += 1
            self._update_info_buffer(infos, dones)

            # Handle timeout by bootstrapping with value function (SB3 GH#633): last reward += gamma * V(s_T)
            if self.baseline == "value" and dones.any():
                rewards = rewards.astype(np.float64)
                for idx in np.flatnonzero(dones):
                    terminal_obs = infos[idx].get("terminal_observation")
                    if infos[idx].get("TimeLimit.truncated", False) and terminal_obs is not None:
                        with th.no_grad():
                            terminal_value = self.policy.predict_values(self.policy.obs_to_tensor(terminal_obs)[0])[0]
                        rewards[idx] += self.gamma * terminal_value.item()

            rollout_buffer.add(self._last_obs, actions, rewards, dones)
            self._last_obs = new_obs
            self._last_episode_starts = dones
            if rollout_buffer.longest_column >= check_at:  # a few checks per rollout: at 1, 2, 4, ... times the length
                check_at *= 2
                self._warn_of_long_episodes(env, rollout_buffer, long_episode)

            callback.update_locals(locals())
            if not callback.on_step():
                return False

        rollout_buffer.compute_returns()
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True

    def _warn_of_long_episodes(self, env: VecEnv, rollout_buffer: EpisodeRolloutBuffer, long_episode: int) -> None:
        """Warn of an episode running for ``long_episode`` steps or more: REINFORCE waits for it to end."""
        running = rollout_buffer.running_steps()
        index = int(np.argmax(running))
        if running[index] < long_episode:
            return
        try:
            spec = env.get_attr("spec", indices=[index])[0]
        except Exception:  # a VecEnv that cannot tell
            spec = None
        where = f"environment {index} of {env.num_envs}"
        name = f"{spec.id} ({where})" if getattr(spec, "id", None) else where.capitalize()
        warnings.warn(
            f"{name} has run one episode for {running[index]:,} steps without "
            f"ending it. REINFORCE learns from whole episodes: if its episodes may never end, give it a time limit "
            f"(gymnasium.wrappers.TimeLimit, or `max_episode_steps` when registering it); at max_rollout_steps="
            f"{self.max_rollout_steps:,} transitions the rollout stops with RolloutLimitError.",
            stacklevel=2,
        )

    def _check_batch_is_finite(self) -> None:
        """
        Refuse a batch whose rewards or observations hold NaN or inf, before any update: the environment gave them.

        :raises FloatingPointError: naming what is non-finite and where; the weights are unchanged
        """
        buffer = self.rollout_buffer
        batch = {"reward": buffer.rewards, **_float_arrays(buffer.observations, "observation")}
        for what, values in batch.items():
            finite = np.isfinite(values).reshape(len(values), -1).all(axis=1)
            if not finite.all():
                first = int(np.argmin(finite))
                raise FloatingPointError(
                    f"The environment returned a non-finite {what} ({(~finite).sum()} of the batch's {len(values)} "
                    f"steps, the first at step {first} of the batch, timestep {self.num_timesteps}): the update was "
                    "skipped and the weights are unchanged. Check the environment: wrap it in SB3's VecCheckNan, or "
                    "train with sb3_reinforce.safeguards.CheckFinite, to name the step and action that produced it."
                )

    def train(self) -> None:
        """One gradient step of the policy on the batch of whole episodes (then the ``n_value_steps`` value steps)."""
        # Switch to train mode (this affects batch norm / dropout)
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        self._check_batch_is_finite()

        batch = next(self.rollout_buffer.get(batch_size=None))
        actions = batch.actions
        if isinstance(self.action_space, spaces.Discrete):
            actions = actions.long().flatten()
        values, log_prob, entropy = self.policy.evaluate_actions(batch.observations, actions)
        values = values.flatten()
        returns = batch.returns

        # Policy gradient theorem, Monte-Carlo estimate (Williams, 1992), with a baseline b_t that ignores a_t:
        #   grad J = E[ sum_t grad log pi(a_t|s_t) * (G_t - b_t) ],   G_t = sum_k gamma^k r_{t+k}
        # unbiased as E[grad log pi(a|s) * b] = b * grad sum_a pi(a|s) = 0, so the loss is
        #   L_pi = -mean_t( log pi(a_t|s_t) * A_t ),  A_t = G_t - b_t, standardized if asked.
        # b_t = V(s_t) (fitted on earlier batches only), the leave-one-out mean of the other episodes' G_t, or 0.
        with_value = self.baseline == "value"
        if with_value:
            advantages = returns - values.detach()
        elif self.baseline == "loo":
            loo = leave_one_out_baseline(self.rollout_buffer.returns, self.rollout_buffer.episode_lengths)
            advantages = returns - th.as_tensor(loo, dtype=returns.dtype, device=returns.device)
        else:
            advantages = returns
        if self.normalize_returns:
            advantages = normalize_returns(advantages)
        policy_loss = -(log_prob * advantages).mean()

        # Entropy bonus (approximated by -log pi when there is no analytical form)
        entropy_loss = -th.mean(-log_prob) if entropy is None else -th.mean(entropy)
        # L_V = mean_t (G_t - V(s_t))^2: in the policy's step (n_value_steps=0), or in n_value_steps steps after it.
        value_loss = F.mse_loss(values, returns) if with_value else th.zeros((), device=returns.device)
        loss = policy_loss + self.ent_coef * entropy_loss
        if with_value and self.n_value_steps == 0:
            loss = loss + self.vf_coef * value_loss

        self.policy.optimizer.zero_grad()
        loss.backward()
        grad_norm = self._clip_grad_norm(self.policy.optimizer, "loss")
        self.policy.optimizer.step()
        if self.value_optimizer is not None:
            value_loss = self._fit_value(batch.observations, returns)

        self._n_updates += 1
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/n_episodes", len(self.rollout_buffer.episode_lengths))
        self.logger.record("train/batch_steps", self.rollout_buffer.batch_size)
        self.logger.record("train/policy_loss", policy_loss.item())
        self.logger.record("train/entropy_loss", entropy_loss.item())
        self.logger.record("train/loss", loss.item())
        self.logger.record("train/grad_norm", grad_norm.item())
        if with_value:
            self.logger.record("train/value_loss", value_loss.item())
            self.logger.record(
                "train/explained_variance", explained_variance(values.detach().cpu().numpy(), returns.cpu().numpy())
            )
        if hasattr(self.policy, "log_std"):
            self.logger.record("train/std", th.exp(self.policy.log_std).mean().item())

    def _fit_value(self, observations: Any, returns: th.Tensor) -> th.Tensor:
        """
        ``n_value_steps`` steps of the value optimizer on ``L_V = mean_t (G_t - V(s_t))^2`` over the whole batch.
        A features extractor shared with the actor (SB3's default) is run once, without a graph, and not trained.

        :return: The last step's loss
        """
        assert self.value_optimizer is not None
        update_learning_rate(self.value_optimizer, self.value_lr_schedule(self._current_progress_remaining))
        policy = self.policy
        predict_values: Callable[[], th.Tensor] = lambda: policy.predict_values(observations)  # noqa: E731
        if policy.share_features_extractor and type(policy).predict_values in (
            ActorCriticPolicy.predict_values,
            ReinforcePolicy.predict_values,
        ):
            with th.no_grad():
                features = BaseModel.extract_features(policy, observations, policy.vf_features_extractor)
            predict_values = lambda: policy.value_net(policy.mlp_extractor.forward_critic(features))  # noqa: E731
        for _ in range(self.n_value_steps):
            value_loss = F.mse_loss(predict_values().flatten(), returns)
            self.value_optimizer.zero_grad()
            value_loss.backward()
            self._clip_grad_norm(self.value_optimizer, "value loss")
            self.value_optimizer.step()
        return value_loss.detach()

    def _clip_grad_norm(self, optimizer: th.optim.Optimizer, what: str) -> th.Tensor:
        """
        Clip the gradients of ``optimizer``'s parameters to ``max_grad_norm`` (None: measure only) and refuse a
        non-finite norm before the optimizer steps.

        :return: The gradients' global norm before clipping
        :raises FloatingPointError: naming the timestep; the gradients are zeroed and the weights unchanged
        """
        parameters = [p for group in optimizer.param_groups for p in group["params"]]
        try:
            if self.max_grad_norm is None:  # the norm only: clipping to inf would multiply every gradient by 1
                return th.nn.utils.get_total_norm([p.grad for p in parameters if p.grad is not None], error_if_nonfinite=True)
            return th.nn.utils.clip_grad_norm_(parameters, self.max_grad_norm, error_if_nonfinite=True)
        except RuntimeError as error:
            optimizer.zero_grad()
            raise FloatingPointError(
                f"Non-finite gradient of the {what} at timestep {self.num_timesteps}: the update was skipped and the "
                "weights are unchanged. Lower the learning rate, normalize the returns or scale the rewards "
                "(VecNormalize); sb3_reinforce.safeguards.CheckFinite names the environment and step of a NaN/inf."
            ) from error

    def learn(
        self: SelfREINFORCE,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int = 10,
        tb_log_name: str = "REINFORCE",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfREINFORCE:
        """
        Train for at least ``total_timesteps`` environment steps (the last batch finishes its episodes, so a little more).

        :param total_timesteps: The total number of environment steps to train on
        :param callback: callback(s) called at every step with state of the algorithm.
        :param log_interval: Log every ``log_interval`` gradient steps (batches)
        :param tb_log_name: the name of the run for TensorBoard logging
        :param reset_num_timesteps: whether or not to reset the current timestep number (used in logging)
        :param progress_bar: Display a progress bar using tqdm and rich.
        :return: the trained model
        """
        return super().learn(
            total_timesteps=total_timesteps,
            callback=callback,
            log_interval=log_interval,
            tb_log_name=tb_log_name,
            reset_num_timesteps=reset_num_timesteps,
            progress_bar=progress_bar,
        )


def _float_arrays(observations: Any, name: str) -> dict[str, np.ndarray]:
    """The floating-point arrays of a batch's observations (an array, or a dict of them), by name."""
    arrays = observations.items() if isinstance(observations, dict) else [(None, observations)]
    return {
        name if key is None else f"{name} {key!r}": array
        for key, array in arrays
        if np.issubdtype(np.asarray(array).dtype, np.floating)
    }


def hyperparameter_defaults() -> dict[str, Any]:
    """
    REINFORCE's hyperparameters: every constructor argument but ``NOT_HYPERPARAMETERS``, with its default, in order
    (read by the checks, the weights-only format and the zoo's search space).
    """
    parameters = inspect.signature(REINFORCE).parameters
    return {name: p.default for name, p in parameters.items() if name not in NOT_HYPERPARAMETERS}


def _is_int(value: Any) -> bool:
    return isinstance(value, Integral) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(float(value))


def _integer(minimum: int) -> tuple[Callable[[Any], bool], str]:
    return (lambda value: _is_int(value) and value >= minimum), f"an integer >= {minimum}"


_LEARNING_RATE = "a finite number >= 0 or a schedule (callable)"
#: Each hyperparameter's (test, allowed values for the error); keys as :func:`hyperparameter_defaults` (tested).
ALLOWED_VALUES: dict[str, tuple[Callable[[Any], bool], str]] = {
    "learning_rate": (lambda v: callable(v) or (_is_number(v) and v >= 0), _LEARNING_RATE),
    "n_episodes": _integer(1),
    "min_steps": _integer(0),
    "gamma": (lambda v: _is_number(v) and 0 <= v <= 1, "a finite number in [0.0, 1.0]"),
    "baseline": (lambda v: v in BASELINES, f"one of {BASELINES}"),
    "normalize_returns": (lambda v: isinstance(v, (bool, np.bool_)), "True or False"),
    "ent_coef": (lambda v: _is_number(v) and v >= 0, "a finite number >= 0"),
    "vf_coef": (lambda v: _is_number(v) and v >= 0, "a finite number >= 0"),
    "n_value_steps": _integer(0),
    "value_learning_rate": (
        lambda v: v is None or callable(v) or (_is_number(v) and v >= 0),
        f"None (the policy's learning rate), {_LEARNING_RATE}",
    ),
    "max_grad_norm": (lambda v: v is None or (_is_number(v) and v > 0), "None (no clipping) or a finite number > 0"),
    "use_sde": (lambda v: isinstance(v, (bool, np.bool_)), "True or False"),
    "sde_sample_freq": _integer(-1),
    "max_rollout_steps": _integer(1),
    "rollout_buffer_class": (lambda v: True, "an EpisodeRolloutBuffer class"),  # checked when the buffer is built
    "rollout_buffer_kwargs": (lambda v: v is None or isinstance(v, dict), "None or a dict of keyword arguments"),
    "stats_window_size": _integer(1),
    "tensorboard_log": (lambda v: v is None or isinstance(v, (str, os.PathLike)), "None or a path"),
    "policy_kwargs": (lambda v: v is None or isinstance(v, dict), "None or a dict of keyword arguments"),
    "verbose": _integer(0),
    "seed": (lambda v: v is None or (_is_int(v) and v >= 0), "None or an integer >= 0"),
}


def check_hyperparameters(values: Mapping[str, Any]) -> None:
    """
    Raise a ``ValueError`` naming the first invalid hyperparameter and the values it allows.

    :param values: REINFORCE's hyperparameters by name (those missing are not checked)
    """
    unknown = sorted(set(values) - set(ALLOWED_VALUES))
    if unknown:
        raise ValueError(f"Unknown REINFORCE hyperparameters {unknown}: the allowed names are {sorted(ALLOWED_VALUES)}")
    for name, value in values.items():
        test, allowed = ALLOWED_VALUES[name]
        if not test(value):
            raise ValueError(f"`{name}` must be {allowed}, got {value!r}")
    if values.get("n_value_steps", 0) and values.get("baseline") != "value":
        raise ValueError(
            f"`n_value_steps` ({values['n_value_steps']}) fits the value baseline: use it with baseline='value', "
            f"got baseline={values.get('baseline')!r}"
        )
    min_steps, max_rollout_steps = values.get("min_steps", 0), values.get("max_rollout_steps", math.inf)
    if min_steps > max_rollout_steps:
        raise ValueError(f"`min_steps` ({min_steps}) cannot exceed `max_rollout_steps` ({max_rollout_steps})")


def _check_spaces(observation_space: spaces.Space, action_space: spaces.Space) -> None:
    """
    Refuse ``Discrete``/``MultiDiscrete`` spaces whose ``start`` is not 0: SB3's preprocessing and distributions
    assume 0, so they would fail inside torch (observations) or silently send actions outside the space.
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
