"""
Training environments stepped by `EnvPool <https://github.com/sail-sg/envpool>`_'s C++ threads (the ``envpool`` extra),
several times faster than Gymnasium on Box2D. :class:`EnvPoolVecEnv` keeps ``DummyVecEnv``'s contract:

- an ended environment is reset at once (``info["terminal_observation"]``, ``info["TimeLimit.truncated"]``);
- ``seed(seed)`` seeds environment ``i`` with ``seed + i`` from the next ``reset()``, which recreates the pool;
- the spaces are Gymnasium's environment's (after the wrappers): models are evaluated, saved and loaded on it;
- episodes are monitored as by SB3's ``Monitor`` (``info["episode"]``, ``monitor.csv``), without a wrapper.

rl_zoo3's ``FrameSkip`` runs in EnvPool and Gymnasium observation wrappers on each observation; other wrappers raise
``ValueError``. ``env_method`` and ``set_attr`` raise ``NotImplementedError``.
"""

import contextlib
import os
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.monitor import ResultsWriter
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

__all__ = [
    "ENVPOOL",
    "ENVPOOL_ENV_IDS",
    "EXTRA_HINT",
    "EnvPoolVecEnv",
    "check_envpool_env",
    "check_envpool_installed",
    "envpool_vec_env_class",
    "make_envpool_vec_env",
    "split_wrappers",
]

#: Gymnasium ids whose EnvPool twin is checked to score as Gymnasium's does (tests/lab/test_envpool.py).
ENVPOOL_ENV_IDS = (
    "CartPole-v1",
    "Acrobot-v1",
    "MountainCar-v0",
    "Pendulum-v1",
    "LunarLander-v3",
    "LunarLanderContinuous-v3",
    "CarRacing-v3",
)

#: The ``--vec-env`` choice (rl_zoo3's ``vec_env_type``) that steps the training environments in EnvPool.
ENVPOOL = "envpool"

#: What to install for EnvPool.
EXTRA_HINT = 'EnvPool is not installed: pip install "sb3-reinforce[envpool]"'

# An (environment) wrapper class and its keyword arguments
WrapperSpec = tuple[type, dict[str, Any]]


def check_envpool_installed() -> None:
    """Raise a ``ModuleNotFoundError`` naming the ``envpool`` extra when EnvPool cannot be imported."""
    try:
        import envpool  # noqa: F401
    except ImportError:
        raise ModuleNotFoundError(EXTRA_HINT, name="envpool") from None


def check_envpool_env(env_id: str) -> None:
    """
    Check, before anything is built, that ``env_id`` can train on EnvPool.

    :param env_id: The environment id
    :raises ModuleNotFoundError: EnvPool is not installed (the message names the extra)
    :raises ValueError: ``env_id`` is not offered (the message lists those that are)
    """
    check_envpool_installed()
    if env_id not in ENVPOOL_ENV_IDS:
        raise ValueError(f"{env_id} is not offered on EnvPool: choose among {', '.join(ENVPOOL_ENV_IDS)}")


@contextlib.contextmanager
def _quiet_float64_bounds() -> Iterator[None]:
    """Silence Gymnasium's "precision lowered" warnings on EnvPool 1.2's spaces (float32 ``Box`` from float64 bounds)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r".*precision lowered by casting to float32", category=UserWarning)
        yield


def _frame_skip_classes() -> tuple[type, ...]:
    """The action-repeat wrappers done natively: rl_zoo3's ``FrameSkip`` (its ``skip`` argument), if installed."""
    with contextlib.suppress(ImportError):
        from rl_zoo3.wrappers import FrameSkip

        return (FrameSkip,)
    return ()


def split_wrappers(wrappers: Sequence[type | WrapperSpec]) -> tuple[int, list[WrapperSpec]]:
    """
    Sort a zoo entry's wrappers into what EnvPool runs: the frame skip and the observation wrappers (the two commute).

    :param wrappers: Wrapper classes, or (class, keyword arguments) pairs, innermost first
    :return: The number of frames each action is repeated, and the observation wrappers in order
    :raises ValueError: for a wrapper without EnvPool equivalent
    """
    frame_skip = 1
    observation_wrappers: list[WrapperSpec] = []
    skip_classes = _frame_skip_classes()
    for wrapper in wrappers:
        wrapper_class, kwargs = (wrapper, {}) if isinstance(wrapper, type) else wrapper
        if skip_classes and issubclass(wrapper_class, skip_classes):
            frame_skip *= int(kwargs.get("skip", 4))  # FrameSkip's default
        elif issubclass(wrapper_class, gym.ObservationWrapper):
            observation_wrappers.append((wrapper_class, dict(kwargs)))
        else:
            raise ValueError(
                f"The wrapper {wrapper_class.__module__}.{wrapper_class.__qualname__} has no EnvPool equivalent: "
                "--vec-env envpool runs rl_zoo3.wrappers.FrameSkip and Gymnasium observation wrappers only"
            )
    return frame_skip, observation_wrappers


class EnvPoolVecEnv(VecEnv):
    """
    ``n_envs`` copies of ``env_id`` stepped in EnvPool's C++ thread pool, with SB3's ``VecEnv`` contract.

    :param env_id: One of :data:`ENVPOOL_ENV_IDS`
    :param n_envs: Number of environments
    :param seed: Environment ``i`` is seeded ``seed + i`` (None: random seeds)
    :param frame_skip: Each action is repeated this many times (rewards summed; an episode's end stops it)
    :param observation_wrappers: Gymnasium observation wrappers (class, keyword arguments), innermost first
    :param env_kwargs: Arguments valid for both Gymnasium's and EnvPool's ``make`` (e.g. ``lap_complete_percent``)
    :param num_threads: EnvPool's worker threads (0: EnvPool's default)
    :param monitor_dir: Where the episodes' ``monitor.csv`` is written (SB3's ``Monitor`` format; None: no file)
    """

    def __init__(
        self,
        env_id: str,
        n_envs: int = 1,
        seed: int | None = None,
        frame_skip: int = 1,
        observation_wrappers: Sequence[WrapperSpec] = (),
        env_kwargs: dict[str, Any] | None = None,
        num_threads: int = 0,
        monitor_dir: str | None = None,
    ) -> None:
        check_envpool_env(env_id)
        import envpool

        if n_envs < 1:
            raise ValueError(f"n_envs must be at least 1, got {n_envs}")
        if frame_skip < 1:
            raise ValueError(f"frame_skip must be at least 1, got {frame_skip}")
        self.env_id = env_id
        self.frame_skip = frame_skip
        self.num_threads = num_threads
        self.env_kwargs = dict(env_kwargs or {})
        unknown = sorted(set(self.env_kwargs) - set(envpool.make_spec(env_id).config._fields))
        if unknown:
            raise ValueError(f"env_kwargs {', '.join(unknown)} of {env_id} are not arguments of its EnvPool environment")
        # Gymnasium's environment, wrapped, gives the spaces and transforms observations; it is never stepped.
        reference = gym.make(env_id, **self.env_kwargs)
        self._observation_wrappers: list[gym.ObservationWrapper] = []
        wrapped: gym.Env = reference
        for wrapper_class, kwargs in observation_wrappers:
            wrapped = wrapper_class(wrapped, **kwargs)
            self._observation_wrappers.append(wrapped)  # type: ignore[arg-type]
        observation_space, action_space = wrapped.observation_space, wrapped.action_space
        self._check_spaces(reference.observation_space, reference.action_space)
        reference.close()
        self._pool: Any = None
        super().__init__(n_envs, observation_space, action_space)
        self.seed(seed)
        self._actions: np.ndarray | None = None
        self._episode_returns = np.zeros(n_envs, dtype=np.float64)
        self._episode_lengths = np.zeros(n_envs, dtype=np.int64)
        self._start_time = time.time()
        self._results_writer: ResultsWriter | None = None
        if monitor_dir is not None:
            self._results_writer = ResultsWriter(
                os.path.join(monitor_dir, "envpool"), header={"t_start": self._start_time, "env_id": env_id}
            )

    def _check_spaces(self, observation_space: gym.Space, action_space: gym.Space) -> None:
        """Check that EnvPool's environment has Gymnasium's observation shape and action space."""
        import envpool

        spec = envpool.make_spec(self.env_id, **self.env_kwargs)
        with _quiet_float64_bounds():
            pool_observation, pool_action = spec.gymnasium_observation_space, spec.gymnasium_action_space
        if (pool_observation.shape, pool_observation.dtype) != (observation_space.shape, observation_space.dtype):
            raise ValueError(
                f"{self.env_id}: EnvPool's observations {pool_observation} differ from Gymnasium's {observation_space}"
            )
        if type(pool_action) is not type(action_space) or pool_action.shape != action_space.shape:
            raise ValueError(f"{self.env_id}: EnvPool's actions {pool_action} differ from Gymnasium's {action_space}")
        self._action_dtype = pool_action.dtype

    def _make_pool(self, seeds: list[int]) -> None:
        import envpool

        if self._pool is not None:
            self._pool.close()
        self._pool = envpool.make(
            self.env_id,
            env_type="gymnasium",
            num_envs=self.num_envs,
            batch_size=self.num_envs,
            num_threads=self.num_threads,
            env_seed=seeds,
            **self.env_kwargs,
        )
        with _quiet_float64_bounds():  # the pool builds its spaces once, when first read (by its reset, say)
            _ = self._pool.observation_space, self._pool.action_space

    def _transform(self, observation: np.ndarray) -> np.ndarray:
        """Apply the observation wrappers to one environment's observation."""
        for wrapper in self._observation_wrappers:
            observation = wrapper.observation(observation)
        return observation

    def _transform_batch(self, observations: np.ndarray) -> np.ndarray:
        if not self._observation_wrappers:
            return observations
        return np.stack([self._transform(observation) for observation in observations])

    def reset(self) -> VecEnvObs:
        """
        Reset all the environments; after ``seed(seed)``, EnvPool's pool is created anew with the seeds.

        :return: The first observations
        """
        if self._pool is None and all(seed is None for seed in self._seeds):
            self.seed(None)  # random seeds, drawn as SB3's VecEnv.seed draws them
        if any(seed is not None for seed in self._seeds):
            self._make_pool([int(seed) for seed in self._seeds])  # type: ignore[arg-type]
        observations, info = self._pool.reset()
        order = np.argsort(info["env_id"])
        self._episode_returns[:] = 0.0
        self._episode_lengths[:] = 0
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._transform_batch(observations[order])

    def step_async(self, actions: np.ndarray) -> None:
        """
        :param actions: One action per environment
        """
        self._actions = np.asarray(actions, dtype=self._action_dtype).reshape(
            (self.num_envs, *(self.action_space.shape or ()))
        )

    def step_wait(self) -> VecEnvStepReturn:
        """
        Step every environment ``frame_skip`` times (stopping at an episode's end), and reset those whose episode ended.

        :return: The observations, rewards, dones and infos, as SB3's ``DummyVecEnv`` gives them
        """
        assert self._actions is not None, "step_async() must come before step_wait()"
        if self._pool is None:
            raise RuntimeError("reset() must be called before step()")
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        observations: np.ndarray | None = None
        active = np.arange(self.num_envs, dtype=np.int32)
        for _ in range(self.frame_skip):
            step_observations, step_rewards, step_terminated, step_truncated, info = self._pool.step(
                self._actions[active], active
            )
            ids = np.asarray(info["env_id"])
            if observations is None:
                observations = np.empty((self.num_envs, *step_observations.shape[1:]), dtype=step_observations.dtype)
            observations[ids] = step_observations
            rewards[ids] += step_rewards
            self._episode_returns[ids] += step_rewards
            self._episode_lengths[ids] += 1
            terminated[ids], truncated[ids] = step_terminated, step_truncated
            active = ids[~(step_terminated | step_truncated)].astype(np.int32)
            if len(active) == 0:
                break
        assert observations is not None
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        new_observations = self._transform_batch(observations)
        ended = np.flatnonzero(dones).astype(np.int32)
        if len(ended):
            reset_observations, reset_info = self._pool.reset(ended)
            first = self._transform_batch(reset_observations)
            for position, env_index in enumerate(np.asarray(reset_info["env_id"])):
                infos[env_index]["terminal_observation"] = new_observations[env_index].copy()  # not a view: overwritten below
                infos[env_index]["TimeLimit.truncated"] = bool(truncated[env_index] and not terminated[env_index])
                infos[env_index]["episode"] = self._end_episode(env_index)
                self.reset_infos[env_index] = {}
                new_observations[env_index] = first[position]
        self._actions = None
        return new_observations, rewards, dones, infos

    def _end_episode(self, env_index: int) -> dict[str, float]:
        """The ended episode's statistics, as SB3's ``Monitor`` gives them (and writes them)."""
        episode = {
            "r": round(float(self._episode_returns[env_index]), 6),
            "l": int(self._episode_lengths[env_index]),
            "t": round(time.time() - self._start_time, 6),
        }
        if self._results_writer is not None:
            self._results_writer.write_row(episode)
        self._episode_returns[env_index] = 0.0
        self._episode_lengths[env_index] = 0
        return episode

    def close(self) -> None:
        """Close EnvPool's pool and the monitor file."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None
        if self._results_writer is not None:
            self._results_writer.close()
            self._results_writer = None

    def _indices_count(self, indices: VecEnvIndices) -> int:
        return len(list(self._get_indices(indices)))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """
        :param attr_name: ``render_mode`` (always None) or an attribute of EnvPool's pool (e.g. ``config``)
        :param indices: Which environments
        :return: The attribute, once per environment
        """
        if attr_name == "render_mode":
            value = None
        elif self._pool is not None and hasattr(self._pool, attr_name):
            value = getattr(self._pool, attr_name)
        else:
            raise AttributeError(f"EnvPool's {self.env_id} environments have no attribute {attr_name!r}")
        return [value] * self._indices_count(indices)

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """EnvPool's environments are C++ objects: their attributes cannot be set."""
        raise NotImplementedError(
            f"set_attr({attr_name!r}): EnvPool's environments are C++ objects whose attributes cannot be set; "
            "use --vec-env dummy or subproc"
        )

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        """EnvPool's environments are C++ objects: their methods cannot be called one by one."""
        raise NotImplementedError(
            f"env_method({method_name!r}): EnvPool's environments are C++ objects without Python methods; "
            "use --vec-env dummy or subproc"
        )

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """
        :param wrapper_class: A Gymnasium wrapper class
        :param indices: Which environments
        :return: Whether the environments have that observation wrapper
        """
        wrapped = any(isinstance(wrapper, wrapper_class) for wrapper in self._observation_wrappers)
        return [wrapped] * self._indices_count(indices)


def make_envpool_vec_env(
    env_id: str,
    n_envs: int = 1,
    seed: int | None = None,
    wrappers: Sequence[type | WrapperSpec] = (),
    env_kwargs: dict[str, Any] | None = None,
    monitor_dir: str | None = None,
    num_threads: int = 0,
) -> EnvPoolVecEnv:
    """
    EnvPool's counterpart of SB3's ``make_vec_env``, each environment monitored as by SB3's ``Monitor``.

    ``REINFORCE("MlpPolicy", make_envpool_vec_env("LunarLander-v3", n_envs=8))``

    :param env_id: One of :data:`ENVPOOL_ENV_IDS`
    :param n_envs: Number of environments
    :param seed: Environment ``i`` is seeded ``seed + i`` (None: random seeds)
    :param wrappers: Wrapper classes or (class, keyword arguments) pairs, innermost first (see :func:`split_wrappers`)
    :param env_kwargs: Arguments of the environment (see :class:`EnvPoolVecEnv`)
    :param monitor_dir: Where the episodes' ``monitor.csv`` is written (None: no file)
    :param num_threads: EnvPool's worker threads (0: EnvPool's default)
    :return: The vectorized environment
    """
    frame_skip, observation_wrappers = split_wrappers(wrappers)
    return EnvPoolVecEnv(env_id, n_envs, seed, frame_skip, observation_wrappers, env_kwargs, num_threads, monitor_dir)


def envpool_vec_env_class(
    env_id: str,
    wrappers: Sequence[type | WrapperSpec] = (),
    env_kwargs: dict[str, Any] | None = None,
    monitor_dir: str | None = None,
    monitor_kwargs: dict[str, Any] | None = None,
    num_threads: int = 0,
) -> Callable[..., VecEnv]:
    """
    A ``vec_env_cls`` for SB3's ``make_vec_env`` (and rl_zoo3's ``create_envs``) building :func:`make_envpool_vec_env`.

    :param env_id: One of :data:`ENVPOOL_ENV_IDS`
    :param wrappers: As :func:`make_envpool_vec_env`'s
    :param env_kwargs: As :func:`make_envpool_vec_env`'s
    :param monitor_dir: As :func:`make_envpool_vec_env`'s
    :param monitor_kwargs: SB3's ``Monitor`` arguments: none is taken (EnvPool's infos have no extra keys)
    :param num_threads: As :func:`make_envpool_vec_env`'s
    :return: The ``vec_env_cls``
    """
    split_wrappers(wrappers)  # a wrapper without EnvPool equivalent fails here, before anything is built
    if monitor_kwargs:
        raise ValueError(f"monitor_kwargs {monitor_kwargs} cannot be given to EnvPool's monitor: it takes none")

    def build(env_fns: Sequence[Callable[[], gym.Env]], **unused: Any) -> VecEnv:
        return make_envpool_vec_env(env_id, len(env_fns), None, wrappers, env_kwargs, monitor_dir, num_threads)

    return build
