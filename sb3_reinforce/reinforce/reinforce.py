from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import FloatSchedule, explained_variance, obs_as_tensor
from stable_baselines3.common.vec_env import VecEnv
from torch.nn import functional as F

from sb3_reinforce.reinforce.buffers import DictEpisodeRolloutBuffer, EpisodeRolloutBuffer
from sb3_reinforce.reinforce.finite_checks import check_step, check_update
from sb3_reinforce.reinforce.hyperparameters import check_spaces, hyperparameter_defaults, validate_hyperparameters
from sb3_reinforce.reinforce.native_memory import HeapTrimmer
from sb3_reinforce.reinforce.persistence import SaveWithRandomState
from sb3_reinforce.reinforce.policies import CnnPolicy, MlpPolicy, MultiInputPolicy, ReinforcePolicy
from sb3_reinforce.reinforce.returns import leave_one_out_baseline, normalize_returns
from sb3_reinforce.reinforce.value_fitting import ValueFitter, bootstrap_truncated

SelfREINFORCE = TypeVar("SelfREINFORCE", bound="REINFORCE")


class REINFORCE(SaveWithRandomState, OnPolicyAlgorithm):
    """
    REINFORCE: Monte-Carlo policy gradient (Williams, 1992), optionally with a learned value baseline.

    Paper: https://link.springer.com/article/10.1007/BF00992696
    Introduction: https://spinningup.openai.com/en/latest/spinningup/rl_intro3.html

    The policy plays whole episodes, then takes one gradient step on
    ``mean_t(-log pi(a_t|s_t) * A_t)``, where ``A_t`` is the discounted reward-to-go ``G_t``
    (standardized over the batch by default), or ``G_t - V(s_t)`` with ``baseline="value"``.
    A rollout always ends on episode boundaries; see :class:`~sb3_reinforce.reinforce.buffers.EpisodeRolloutBuffer`
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
        :func:`~sb3_reinforce.reinforce.returns.leave_one_out_baseline`). ``"loo"`` needs at least two episodes per batch
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
    :param rollout_buffer_class: Rollout buffer class to use, an :class:`~sb3_reinforce.reinforce.buffers.EpisodeRolloutBuffer`
        (or a subclass; SB3's fixed-length ``RolloutBuffer`` cannot hold whole episodes). If ``None``, it will be
        automatically selected.
    :param rollout_buffer_kwargs: Keyword arguments to pass to the rollout buffer on creation.
    :param stats_window_size: Window size for the rollout logging, specifying the number of episodes to average
        the reported success rate, mean episode length, and mean reward over
    :param tensorboard_log: the log location for tensorboard (if None, no logging)
    :param policy_kwargs: additional arguments to be passed to the policy on creation. See
        :class:`~sb3_reinforce.reinforce.policies.ReinforcePolicy` (``net_arch``, ``activation_fn``, ``xavier_init``, ...)
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
    #: resident memory of a long run keeps growing (see :mod:`sb3_reinforce.reinforce.native_memory`).
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
        arguments = locals()  # every hyperparameter is checked, by the table derived from this signature
        validate_hyperparameters({name: arguments[name] for name in hyperparameter_defaults(REINFORCE)})
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
        self.value_fitter: ValueFitter | None = None
        self.value_optimizer: th.optim.Optimizer | None = None  # saved and loaded by SB3 under this name
        if self.n_value_steps > 0:
            value_lr = self.learning_rate if self.value_learning_rate is None else self.value_learning_rate
            self.value_fitter = ValueFitter(self.policy, self.n_value_steps, FloatSchedule(value_lr), self.max_grad_norm)
            self.value_optimizer = self.value_fitter.optimizer
        self._heap_trimmer = HeapTrimmer(self.heap_trim_interval)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_heap_trimmer", "value_fitter"]

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
            check_step(new_obs, rewards, self.num_timesteps)
            self.num_timesteps += env.num_envs
            n_steps += 1
            self._update_info_buffer(infos, dones)
            if self.baseline == "value":  # a truncated episode's return goes on as gamma * V(s_T) (SB3 GH#633)
                rewards = bootstrap_truncated(self.policy, self.gamma, rewards, dones, infos, self.num_timesteps)
            rollout_buffer.add(self._last_obs, actions, rewards, dones)
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
        grad_norm = check_update(
            loss,
            [p for group in self.policy.optimizer.param_groups for p in group["params"]],
            self.policy.optimizer,
            self.max_grad_norm,
            "loss",
            "Lower the learning rate, normalize the returns (normalize_returns=True) or scale the rewards (VecNormalize).",
            self.num_timesteps,
        )
        self.policy.optimizer.step()
        if self.value_fitter is not None:
            value_loss = self.value_fitter.fit(
                batch.observations, returns, self._current_progress_remaining, self.num_timesteps
            )

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
