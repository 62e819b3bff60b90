import io
import pathlib
from collections.abc import Callable, Iterable
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.base_class import SelfBaseAlgorithm
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.policies import BaseModel, BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import FloatSchedule, explained_variance, obs_as_tensor, update_learning_rate
from stable_baselines3.common.vec_env import VecEnv
from torch.nn import functional as F

from sb3_reinforce.buffers import DictEpisodeRolloutBuffer, EpisodeRolloutBuffer
from sb3_reinforce.native_memory import HeapTrimmer
from sb3_reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy, ReinforcePolicy
from sb3_reinforce.returns import leave_one_out_baseline, normalize_returns
from sb3_reinforce.rng import get_rng_state, set_rng_state
from sb3_reinforce.safe_io import check_model_file
from sb3_reinforce.validation import check_spaces, validate_hyperparameters

SelfREINFORCE = TypeVar("SelfREINFORCE", bound="REINFORCE")


class NonFiniteError(FloatingPointError):
    """An environment returned a NaN/inf reward or observation, or the loss/gradient became non-finite."""


def _non_finite_parts(obs: Any) -> list[tuple[str | None, np.ndarray]]:
    """The floating-point parts of an observation (an array, or a dict of arrays) that hold a NaN or an inf."""
    parts = obs.items() if isinstance(obs, dict) else [(None, obs)]
    arrays = [(key, np.asarray(value)) for key, value in parts]
    return [(key, a) for key, a in arrays if np.issubdtype(a.dtype, np.floating) and not np.isfinite(a).all()]


def _total_grad_norm(parameters: Iterable[th.Tensor]) -> th.Tensor:
    """The global 2-norm of the parameters' gradients, as ``clip_grad_norm_`` computes it, without clipping."""
    parameters = list(parameters)
    if hasattr(th.nn.utils, "get_total_norm"):  # torch >= 2.6
        return th.nn.utils.get_total_norm([p.grad for p in parameters if p.grad is not None])
    return th.nn.utils.clip_grad_norm_(parameters, float("inf"))  # older torch: the same norm (a x1 rescale)


class REINFORCE(OnPolicyAlgorithm):
    """
    REINFORCE: Monte-Carlo policy gradient (Williams, 1992), optionally with a learned value baseline.

    Paper: https://link.springer.com/article/10.1007/BF00992696
    Introduction: https://spinningup.openai.com/en/latest/spinningup/rl_intro3.html

    The policy plays whole episodes, then takes one gradient step on
    ``mean_t(-log pi(a_t|s_t) * A_t)``, where ``A_t`` is the discounted reward-to-go ``G_t``
    (standardized over the batch by default), or ``G_t - V(s_t)`` with ``baseline="value"``.
    A rollout always ends on episode boundaries; see :class:`~sb3_reinforce.buffers.EpisodeRolloutBuffer`
    for what happens to episodes still running in other environments when the batch is full.

    The estimator is unbiased but has high variance. A baseline reduces it without adding bias: any ``b`` that
    does not depend on the action ``a_t`` leaves the expected gradient unchanged, since
    ``E[grad log pi(a|s) * b] = b * grad sum_a pi(a|s) = 0``. Two are offered: a learned ``V(s_t)``
    (``baseline="value"``, fitted on earlier batches only when it is read, so it cannot depend on this batch's
    actions) and a critic-free leave-one-out mean over the batch's other episodes (``baseline="loo"``).
    Truncated episodes (time limits) are bootstrapped with ``gamma * V(s_T)`` when there is a value baseline,
    and are treated as terminal otherwise (no estimate of the future exists).

    :param policy: The policy model to use (MlpPolicy, CnnPolicy, MultiInputPolicy, or a class)
    :param env: The environment to learn from (if registered in Gym, can be str)
    :param learning_rate: The learning rate, it can be a function of the current progress remaining (from 1 to 0)
    :param n_episodes: Number of whole episodes to collect per environment per gradient step (the seed
        used 1, with one environment). As SB3's ``n_steps``, it counts per environment: a batch holds at
        least ``n_episodes * n_envs`` finished episodes (several may end at the same step, so a batch can
        hold more).
    :param min_steps: Minimum number of environment steps per gradient step, all environments together:
        episodes are added to the batch until both ``n_episodes * n_envs`` episodes and ``min_steps`` steps
        are reached (0: count episodes only)
    :param gamma: Discount factor, in [0, 1]
    :param baseline: ``None`` for plain REINFORCE (no value network is built), ``"value"`` for REINFORCE
        with a learned state-value baseline ``V(s)`` trained by regression on the returns, or ``"loo"`` for the
        critic-free leave-one-out baseline: for step ``t`` of an episode, the mean return ``G_t`` of the batch's
        *other* episodes that lasted past step ``t`` (0 where none did; see
        :func:`~sb3_reinforce.returns.leave_one_out_baseline`). ``"loo"`` needs at least two episodes per batch
        (``n_episodes * n_envs >= 2``), which is checked when the model is built.
    :param normalize_returns: Standardize the policy-gradient weights over the batch (returns without a
        baseline, advantages ``G_t - V(s_t)`` with one). A batch of equal returns gives zero weights, never NaN.
    :param ent_coef: Entropy coefficient for the loss calculation
    :param vf_coef: Value function coefficient for the loss calculation (used only with ``baseline="value"``
        and ``n_value_steps=0``)
    :param n_value_steps: Gradient steps that fit the value baseline to each batch's returns, after the policy's
        one step, with an optimizer of their own (Spinning Up's VPG takes 80). 0 (default): the value head takes
        one joint step with the policy on ``policy_loss + vf_coef * value_loss``, as A2C. Only with
        ``baseline="value"``. Either way the policy takes one step per batch, with advantages computed from
        ``V`` before it was fitted to this batch. With a shared features extractor (``CnnPolicy``'s default),
        the value steps train the value layers only and the extractor learns from the policy loss.
    :param value_learning_rate: Learning rate of the value steps (``n_value_steps > 0``), a number or a
        schedule of the progress remaining; None (default): the policy's ``learning_rate``
    :param max_grad_norm: The maximum value for the gradient clipping, or None (default) for no clipping.
        Unlike A2C/PPO's 0.5, the default does not clip: with ``baseline="value"`` the critic's early
        gradient (an MSE on raw returns) dominates a global norm, and clipping it starves the actor
        (CartPole-v1, 5 seeds, steps to an evaluation mean of 475: clipped at 0.5, 4/5 solved within 60k,
        median 18k; unclipped, 5/5, median 8k). Without a baseline, clipping at 0.5 was a little faster
        (median 6k vs 10k steps). See ``benchmarks/grad_clip_ablation.py``. The seed did not clip.
    :param use_sde: Whether to use generalized State Dependent Exploration (gSDE)
        instead of action noise exploration (default: False)
    :param sde_sample_freq: Sample a new noise matrix every n steps when using gSDE
        Default: -1 (only sample at the beginning of the rollout)
    :param max_rollout_steps: Most transitions the rollout buffer may hold (all environments together).
        An environment that has not ended enough episodes by then raises ``RolloutLimitError`` instead of
        exhausting memory: give it a time limit, or raise this cap (memory is about this many observations).
    :param rollout_buffer_class: Rollout buffer class to use, an :class:`~sb3_reinforce.buffers.EpisodeRolloutBuffer`
        (or a subclass; SB3's fixed-length ``RolloutBuffer`` cannot hold whole episodes). If ``None``, it will be
        automatically selected.
    :param rollout_buffer_kwargs: Keyword arguments to pass to the rollout buffer on creation.
    :param stats_window_size: Window size for the rollout logging, specifying the number of episodes to average
        the reported success rate, mean episode length, and mean reward over
    :param tensorboard_log: the log location for tensorboard (if None, no logging)
    :param policy_kwargs: additional arguments to be passed to the policy on creation. See
        :class:`~sb3_reinforce.policies.ReinforcePolicy` (``net_arch``, ``activation_fn``, ``xavier_init``, ...)
    :param verbose: Verbosity level: 0 for no output, 1 for info messages (such as device or wrappers used), 2 for
        debug messages
    :param seed: Seed for the pseudo random generators
    :param device: Device (cpu, cuda, ...) on which the code should be run.
        Setting it to auto, the code will be run on the GPU if possible.
    :param _init_setup_model: Whether or not to build the network at the creation of the instance
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {
        "MlpPolicy": MlpPolicy,
        "CnnPolicy": CnnPolicy,
        "MultiInputPolicy": MultiInputPolicy,
    }
    rollout_buffer: EpisodeRolloutBuffer  # type: ignore[assignment]
    #: Environment steps between two returns of the C heap's free memory to the OS (glibc ``malloc_trim``),
    #: or None for never. Whole-episode batches allocate a new size at every update, and without this the
    #: resident memory of a long run keeps growing (see :mod:`sb3_reinforce.native_memory`).
    heap_trim_interval: ClassVar[int | None] = 10_000

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
        validate_hyperparameters(
            learning_rate=learning_rate,
            n_episodes=n_episodes,
            min_steps=min_steps,
            gamma=gamma,
            baseline=baseline,
            normalize_returns=normalize_returns,
            ent_coef=ent_coef,
            vf_coef=vf_coef,
            max_grad_norm=max_grad_norm,
            max_rollout_steps=max_rollout_steps,
            n_value_steps=n_value_steps,
            value_learning_rate=value_learning_rate,
        )
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
            self._setup_model()

    def _setup_model(self) -> None:
        check_spaces(self.observation_space, self.action_space)
        if self.baseline == "loo" and self.n_episodes * self.n_envs < 2:
            raise ValueError(
                f"baseline='loo' compares each episode with the other episodes of its batch, but a batch holds "
                f"n_episodes * n_envs = {self.n_episodes} * {self.n_envs} = 1 episode: set n_episodes >= 2 or n_envs >= 2"
            )
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
        self.value_optimizer: th.optim.Optimizer | None = None
        if self.n_value_steps > 0:
            value_lr = self.learning_rate if self.value_learning_rate is None else self.value_learning_rate
            self.value_lr_schedule = FloatSchedule(value_lr)
            self.value_optimizer = self.policy.optimizer_class(  # type: ignore[call-arg]
                self._value_parameters(), lr=self.value_lr_schedule(1), **self.policy.optimizer_kwargs
            )
        self._heap_trimmer = HeapTrimmer(self.heap_trim_interval)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_heap_trimmer"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        state_dicts, variables = super()._get_torch_save_params()
        if self.value_optimizer is not None:
            state_dicts = [*state_dicts, "value_optimizer"]
        return state_dicts, variables

    def _value_parameters(self) -> list[th.nn.Parameter]:
        """The parameters that only ``V(s)`` uses: the value layers, and the critic's own features extractor."""
        policy = self.policy
        modules = [policy.mlp_extractor.value_net, policy.value_net]
        if not policy.share_features_extractor:
            modules.append(policy.vf_features_extractor)
        return [param for module in modules for param in module.parameters()]

    def _value_predictor(self, observations: Any) -> Callable[[], th.Tensor]:
        """
        ``V(s)`` of the batch, as a function each value step calls. With a features extractor shared with the
        actor (SB3's default), the features do not depend on the value parameters and the value steps do not
        change them: they are computed once, without a graph, and each step runs the critic's layers only. The
        loss and its gradients are those of ``predict_values``; with a CNN, the extractor's forward and backward
        pass were most of the cost of every step. Otherwise (a critic with its own extractor, or a policy that
        overrides ``predict_values``), each step calls ``predict_values``.
        """
        policy = self.policy
        if not policy.share_features_extractor or type(policy).predict_values is not ReinforcePolicy.predict_values:
            return lambda: policy.predict_values(observations)
        with th.no_grad():
            features = BaseModel.extract_features(policy, observations, policy.vf_features_extractor)
        return lambda: policy.value_net(policy.mlp_extractor.forward_critic(features))

    def _fit_value_baseline(self, observations: Any, returns: th.Tensor) -> th.Tensor:
        """
        ``n_value_steps`` gradient steps on ``L_V = mean_t (G_t - V(s_t))^2`` over the whole batch (the value
        parameters only), after the policy step. Returns the last step's loss.
        """
        assert self.value_optimizer is not None
        update_learning_rate(self.value_optimizer, self.value_lr_schedule(self._current_progress_remaining))
        parameters = [p for group in self.value_optimizer.param_groups for p in group["params"]]
        predict_values = self._value_predictor(observations)
        for _ in range(self.n_value_steps):
            value_loss = F.mse_loss(predict_values().flatten(), returns)
            self.value_optimizer.zero_grad()
            value_loss.backward()
            if self.max_grad_norm is not None:
                grad_norm = th.nn.utils.clip_grad_norm_(parameters, self.max_grad_norm)
            else:
                grad_norm = _total_grad_norm(parameters)
            if not (th.isfinite(value_loss) and th.isfinite(grad_norm)):
                self.value_optimizer.zero_grad()
                raise NonFiniteError(
                    f"Non-finite value loss ({value_loss.item()}) or gradient norm ({grad_norm.item()}) at timestep "
                    f"{self.num_timesteps}: the value step was skipped and the value weights are unchanged. "
                    "Lower value_learning_rate or scale the rewards (VecNormalize)."
                )
            self.value_optimizer.step()
        return value_loss.detach()

    def _setup_learn(
        self,
        total_timesteps: int,
        callback: MaybeCallback = None,
        reset_num_timesteps: bool = True,
        tb_log_name: str = "run",
        progress_bar: bool = False,
    ) -> tuple[int, BaseCallback]:
        env_will_reset = reset_num_timesteps or self._last_obs is None
        result = super()._setup_learn(total_timesteps, callback, reset_num_timesteps, tb_log_name, progress_bar)
        if env_will_reset:
            # Running episodes belong to the environment state that the reset discards.
            self.rollout_buffer.reset()
        return result

    def _update_current_progress_remaining(self, num_timesteps: int, total_timesteps: int) -> None:
        # The last batch finishes its episodes past total_timesteps: without the floor, a schedule would be read
        # at a negative progress (a linear learning rate below 0, i.e. one step of gradient *ascent*).
        super()._update_current_progress_remaining(num_timesteps, total_timesteps)
        self._current_progress_remaining = max(0.0, self._current_progress_remaining)

    def _check_finite(self, new_obs: Any, rewards: np.ndarray) -> None:
        # Fast path, once per step: a NaN/inf anywhere makes a sum non-finite (a sum that overflows only
        # sends us on to the exact checks below, which then find nothing).
        parts = new_obs.values() if isinstance(new_obs, dict) else (new_obs,)
        if np.isfinite(rewards.sum()) and all(
            isinstance(part, np.ndarray) and (part.dtype.kind != "f" or np.isfinite(part.sum())) for part in parts
        ):
            return
        if not np.isfinite(rewards).all():
            env_idx = int(np.flatnonzero(~np.isfinite(rewards))[0])
            raise NonFiniteError(
                f"Environment {env_idx} returned a non-finite reward ({rewards[env_idx]}) at timestep {self.num_timesteps}: "
                "REINFORCE cannot learn from it (check the environment's reward, or wrap it to clip rewards)."
            )
        for key, obs in _non_finite_parts(new_obs):
            env_idx = int(np.flatnonzero(~np.isfinite(obs.reshape(len(obs), -1)).all(axis=1))[0])
            self._raise_non_finite_obs("observation", env_idx, key, obs[env_idx], "REINFORCE cannot learn from it")

    def _check_finite_terminal(self, env_idx: int, terminal_obs: Any) -> None:
        # The terminal observation of a truncated episode is read only here, to bootstrap with V(s_T).
        for key, obs in _non_finite_parts(terminal_obs):
            self._raise_non_finite_obs(
                "terminal observation", env_idx, key, obs, "REINFORCE cannot bootstrap the truncated episode from it"
            )

    def _raise_non_finite_obs(self, what: str, env_idx: int, key: str | None, value: np.ndarray, consequence: str) -> None:
        where = f" (key {key!r})" if key is not None else ""
        raise NonFiniteError(
            f"Environment {env_idx} returned a non-finite {what}{where} at timestep {self.num_timesteps}: {value}. "
            f"{consequence} (check the environment, or use VecCheckNan to find the cause)."
        )

    def _bootstrap_truncated(self, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]) -> np.ndarray:
        """
        With a value baseline, add ``gamma * V(s_T)`` to the last reward of every truncated episode, so that its
        return estimates what the time limit cut off (as SB3's A2C/PPO do, GH#633). Without one, do nothing:
        the truncated episode is treated as terminal.
        """
        if self.baseline != "value" or not dones.any():
            return rewards
        rewards = rewards.astype(np.float64)
        for idx in np.flatnonzero(dones):
            if infos[idx].get("TimeLimit.truncated", False) and infos[idx].get("terminal_observation") is not None:
                self._check_finite_terminal(int(idx), infos[idx]["terminal_observation"])
                terminal_obs = self.policy.obs_to_tensor(infos[idx]["terminal_observation"])[0]
                with th.no_grad():
                    terminal_value = self.policy.predict_values(terminal_obs)[0].item()
                rewards[idx] += self.gamma * terminal_value
        return rewards

    def collect_rollouts(
        self,
        env: VecEnv,
        callback: BaseCallback,
        rollout_buffer: RolloutBuffer,
        n_rollout_steps: int,
    ) -> bool:
        """
        Play the current policy until the buffer holds a batch of whole episodes, then compute their returns.

        Callbacks see the same local variables as with SB3's on-policy algorithms (``new_obs``, ``rewards``,
        ``dones``, ``infos``, ...). Each transition is stored before ``callback.on_step()``, so stopping from
        a callback loses no experience: ``learn(..., reset_num_timesteps=False)`` goes on from there.

        :param env: The training environment
        :param callback: Callback that will be called at each step (and at the beginning and end of the rollout)
        :param rollout_buffer: An :class:`EpisodeRolloutBuffer`
        :param n_rollout_steps: Unused: the rollout length is set by ``n_episodes`` and ``min_steps``
        :return: True if the batch is complete, False if a callback stopped training first.
        """
        assert self._last_obs is not None, "No previous observation was provided"
        assert isinstance(rollout_buffer, EpisodeRolloutBuffer), "REINFORCE needs an EpisodeRolloutBuffer"
        # The last update's tensors are freed by now: give the heap's free pages back (every heap_trim_interval steps).
        self._heap_trimmer.step(self.num_timesteps)
        # Switch to eval mode (this affects batch norm / dropout)
        self.policy.set_training_mode(False)
        n_steps = 0
        if self.use_sde:
            self.policy.reset_noise(env.num_envs)

        # Only the actor runs here: log pi(a|s) (and V(s)) are evaluated with gradients in train().
        sampler = self.policy.fast_sampler() if isinstance(self.policy, ReinforcePolicy) else None

        callback.on_rollout_start()

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
            self._check_finite(new_obs, rewards)
            self.num_timesteps += env.num_envs
            n_steps += 1
            self._update_info_buffer(infos, dones)
            rollout_buffer.add(self._last_obs, actions, self._bootstrap_truncated(rewards, dones, infos), dones)
            self._last_obs = new_obs
            self._last_episode_starts = dones

            # Give access to local variables
            callback.update_locals(locals())
            if not callback.on_step():
                return False

        rollout_buffer.compute_returns()
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True

    def train(self) -> None:
        """
        One gradient step on the batch of whole episodes in the rollout buffer.
        """
        # Switch to train mode (this affects batch norm / dropout)
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)

        batch = next(self.rollout_buffer.get(batch_size=None))
        actions = batch.actions
        if isinstance(self.action_space, spaces.Discrete):
            # Convert discrete action from float to long
            actions = actions.long().flatten()
        values, log_prob, entropy = self.policy.evaluate_actions(batch.observations, actions)
        values = values.flatten()
        returns = batch.returns

        # Policy gradient theorem, Monte-Carlo estimate (Williams, 1992), with a baseline b that ignores a_t:
        #   grad J = E[ sum_t grad log pi(a_t|s_t) * (G_t - b_t) ],   G_t = sum_k gamma^k r_{t+k}
        # so the loss is  L_pi = -mean_t( log pi(a_t|s_t) * A_t ),  A_t = G_t - b_t, standardized if asked.
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
        # The baseline regresses on the returns: L_V = mean_t (G_t - V(s_t))^2, in the same step as the policy
        # (n_value_steps=0), or in n_value_steps steps of its own after it.
        joint_value_step = with_value and self.n_value_steps == 0
        value_loss = F.mse_loss(values, returns) if with_value else th.zeros((), device=returns.device)
        loss = policy_loss + self.ent_coef * entropy_loss
        if joint_value_step:
            loss = loss + self.vf_coef * value_loss

        self.policy.optimizer.zero_grad()
        loss.backward()
        if self.max_grad_norm is not None:
            grad_norm = th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
        else:  # the norm only (logged, and checked below): no clipping, so no rescaling of every gradient
            grad_norm = _total_grad_norm(p for group in self.policy.optimizer.param_groups for p in group["params"])
        if not (th.isfinite(loss) and th.isfinite(grad_norm)):
            self.policy.optimizer.zero_grad()
            raise NonFiniteError(
                f"Non-finite loss ({loss.item()}) or gradient norm ({grad_norm.item()}) at timestep {self.num_timesteps}: "
                "the update was skipped and the weights are unchanged. Lower the learning rate, normalize the returns "
                "(normalize_returns=True) or scale the rewards (VecNormalize)."
            )
        self.policy.optimizer.step()
        if with_value and not joint_value_step:
            value_loss = self._fit_value_baseline(batch.observations, returns)

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

    def save(
        self,
        path: str | pathlib.Path | io.BufferedIOBase,
        exclude: Any = None,
        include: Any = None,
    ) -> None:
        """
        Save the model as SB3 does, plus the states of the torch, numpy and ``random`` generators, so that
        loading a seeded model continues its random stream (see :meth:`load`).

        :param path: path to the file where the agent should be saved
        :param exclude: name of parameters that should be excluded in addition to the default ones
        :param include: name of parameters that might be excluded but should be included anyway
        """
        self._rng_state = get_rng_state()
        try:
            super().save(path, exclude, include)
        finally:
            del self._rng_state

    @classmethod
    def load(
        cls: type[SelfBaseAlgorithm],
        path: str | pathlib.Path | io.BufferedIOBase,
        env: GymEnv | None = None,
        device: th.device | str = "auto",
        custom_objects: dict[str, Any] | None = None,
        print_system_info: bool = False,
        force_reset: bool = True,
        **kwargs: Any,
    ) -> SelfBaseAlgorithm:
        """
        Load a model saved by :meth:`save` (SB3's format: only load files you trust, it unpickles objects;
        see :func:`sb3_reinforce.safe_io.load_weights` for a format that does not).

        The file is checked first: a truncated or corrupted file raises
        :class:`~sb3_reinforce.safe_io.CorruptModelFileError`. For a model with a ``seed``, the random generators
        are restored to their state at save time (instead of being reseeded from ``seed``, as SB3 does).

        Takes SB3's ``BaseAlgorithm.load`` arguments.
        """
        check_model_file(path)
        model = super().load(path, env, device, custom_objects, print_system_info, force_reset, **kwargs)
        rng_state = model.__dict__.pop("_rng_state", None)
        if rng_state is not None and model.seed is not None:
            set_rng_state(rng_state)
        return model

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
        Train for at least ``total_timesteps`` environment steps (all environments counted). The last batch
        finishes its episodes, so training may run a little past ``total_timesteps``.

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
