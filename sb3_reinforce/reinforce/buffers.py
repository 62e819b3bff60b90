"""Full-episode rollout buffers: a batch is made of whole episodes, so no return is ever cut."""

from collections.abc import Generator
from typing import Any, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import BaseBuffer
from stable_baselines3.common.type_aliases import TensorDict

from sb3_reinforce.reinforce.returns import discounted_returns, episode_bounds

__all__ = [
    "DictEpisodeRolloutBuffer",
    "DictEpisodeRolloutBufferSamples",
    "EpisodeRolloutBuffer",
    "EpisodeRolloutBufferSamples",
    "RolloutLimitError",
]


class EpisodeRolloutBufferSamples(NamedTuple):
    observations: th.Tensor
    actions: th.Tensor
    returns: th.Tensor


class DictEpisodeRolloutBufferSamples(NamedTuple):
    observations: TensorDict
    actions: th.Tensor
    returns: th.Tensor


class RolloutLimitError(RuntimeError):
    """Raised when the buffer would exceed ``max_steps`` transitions before the batch holds its episodes."""


def _storage_dtype(space: spaces.Space) -> np.dtype:
    # Images stay uint8 (SB3's RolloutBuffer stores float32); float64 becomes float32.
    dtype = np.dtype(space.dtype if space.dtype is not None else np.float32)
    return np.dtype(np.float32) if dtype == np.float64 else dtype


class EpisodeRolloutBuffer(BaseBuffer):
    """
    Rollout buffer for REINFORCE that holds whole episodes.

    Full once it holds at least ``n_episodes`` finished episodes and ``min_steps`` of their steps: :meth:`compute_returns` then
    takes them all out as the batch; episodes still running go on in the next one. The last batch is readable under
    SB3's ``RolloutBuffer`` names (``observations``, ``actions``, ``rewards``, ``returns``, ``episode_starts``).
    The capacity doubles as needed; past ``max_steps`` transitions, :class:`RolloutLimitError` is raised.

    :param buffer_size: Initial capacity, in steps per environment (grows as needed)
    :param observation_space: Observation space
    :param action_space: Action space
    :param device: PyTorch device for the returned tensors
    :param gamma: Discount factor
    :param n_envs: Number of parallel environments
    :param n_episodes: Minimum number of finished episodes in a batch
    :param min_steps: Minimum number of steps (summed over the finished episodes) in a batch
    :param max_steps: Maximum number of transitions stored at once (all environments together)
    """

    observation_space: spaces.Space
    obs_shape: tuple[int, ...]

    def __init__(
        self,
        buffer_size: int,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        device: th.device | str = "auto",
        gamma: float = 0.99,
        n_envs: int = 1,
        n_episodes: int = 1,
        min_steps: int = 0,
        max_steps: int = 1_000_000,
    ):
        super().__init__(buffer_size, observation_space, action_space, device, n_envs=n_envs)
        self.gamma = gamma
        self.n_episodes = n_episodes
        self.min_steps = min_steps
        self.max_steps = max_steps
        self.max_rows = max(1, max_steps // n_envs)
        self.capacity = max(1, min(buffer_size, self.max_rows))
        self._env_indices = np.arange(n_envs)
        self.reset()

    def _obs_specs(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        return {"observations": (tuple(self.obs_shape), _storage_dtype(self.observation_space))}

    def _split_obs(self, obs: Any) -> dict[str, np.ndarray]:
        return {"observations": obs}

    def _join_obs(self, arrays: dict[str, np.ndarray]) -> Any:
        return self.to_torch(arrays["observations"])

    def _field_specs(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        return {
            **self._obs_specs(),
            "actions": ((self.action_dim,), np.dtype(np.float32)),
            "rewards": ((), np.dtype(np.float64)),
            "episode_ends": ((), np.dtype(bool)),
        }

    def reset(self) -> None:
        """Forget everything, running episodes included (used when the environment is reset)."""
        self._storage = {
            name: np.zeros((self.capacity, self.n_envs, *shape), dtype=dtype)
            for name, (shape, dtype) in self._field_specs().items()
        }
        self._flat = self._flat_views()
        # Rows written per environment, and rows that belong to finished episodes (a prefix of the column)
        self.env_steps = np.zeros(self.n_envs, dtype=np.int64)
        self.finished_steps = np.zeros(self.n_envs, dtype=np.int64)
        self.n_finished_episodes = 0
        # The last batch: empty arrays until the first, so that its attributes can always be read
        self._batch = {name: np.zeros((0, *shape), dtype=dtype) for name, (shape, dtype) in self._field_specs().items()}
        self.returns = np.zeros(0, dtype=np.float64)
        self.episode_lengths = np.zeros(0, dtype=np.int64)
        self.batch_size = 0
        super().reset()

    @property
    def observations(self) -> Any:
        """The last batch's observations, ``(batch_size, *obs_shape)``."""
        return self._batch["observations"]

    @property
    def actions(self) -> np.ndarray:
        """The last batch's actions, ``(batch_size, action_dim)``."""
        return self._batch["actions"]

    @property
    def rewards(self) -> np.ndarray:
        """The last batch's rewards, ``(batch_size,)`` (bootstrapped on truncation when the algorithm does it)."""
        return self._batch["rewards"]

    @property
    def episode_starts(self) -> np.ndarray:
        """1.0 on the first step of each episode of the last batch, else 0.0, ``(batch_size,)``."""
        ends = self._batch["episode_ends"]
        starts = np.ones(len(ends), dtype=np.float32)
        starts[1:] = ends[:-1]
        return starts

    @property
    def env_steps(self) -> np.ndarray:
        """Rows written per environment: the lengths so far of its finished and running episodes."""
        return self._env_steps

    @env_steps.setter
    def env_steps(self, value: np.ndarray) -> None:
        self._env_steps = np.array(value, dtype=np.int64)
        # Kept with it for add(): the flat row of each environment's next write, and the longest column.
        self._next_index = self._env_steps * self.n_envs + self._env_indices
        self._longest = int(self._env_steps.max())

    def size(self) -> int:
        """Number of transitions currently stored (finished and running episodes)."""
        return int(self.env_steps.sum())

    @property
    def longest_column(self) -> int:
        """Rows written in the fullest environment's column (its finished and running episodes)."""
        return self._longest

    def running_steps(self) -> np.ndarray:
        """Each environment's running episode's steps so far, ``(n_envs,)``."""
        return self._env_steps - self.finished_steps

    @property
    def is_full(self) -> bool:
        """Whether the finished episodes make a batch (``n_episodes`` of them and ``min_steps`` steps)."""
        return self.n_finished_episodes >= self.n_episodes and int(self.finished_steps.sum()) >= self.min_steps

    def _grow(self) -> None:
        if self.capacity >= self.max_rows:
            longest = int(self.env_steps.max())
            raise RolloutLimitError(
                f"The rollout buffer holds {self.size()} transitions ({longest} steps in one environment) "
                f"and reached its limit, max_rollout_steps={self.max_steps}, before {self.n_episodes} episode(s) "
                "finished. REINFORCE learns from whole episodes: give the environment a time limit "
                "(e.g. gymnasium.wrappers.TimeLimit or `max_episode_steps`), or raise `max_rollout_steps`."
            )
        new_capacity = min(2 * self.capacity, self.max_rows)
        for name, array in self._storage.items():
            grown = np.zeros((new_capacity, *array.shape[1:]), dtype=array.dtype)
            grown[: self.capacity] = array
            self._storage[name] = grown
        self.capacity = new_capacity
        self._flat = self._flat_views()

    def _flat_views(self) -> dict[str, np.ndarray]:
        # Views (no copy) of the storage with time and env merged: row ``t * n_envs + env``.
        return {name: array.reshape(-1, *array.shape[2:]) for name, array in self._storage.items()}

    def add(self, obs: Any, action: np.ndarray, reward: np.ndarray, episode_end: np.ndarray) -> None:
        """
        Store one step of every environment.

        :param obs: Observations the actions were taken in, shape ``(n_envs, *obs_shape)``
        :param action: Actions taken, shape ``(n_envs, *action_shape)``
        :param reward: Rewards received (bootstrapped on truncation by the caller if wanted), shape ``(n_envs,)``
        :param episode_end: True where this step ended the environment's episode, shape ``(n_envs,)``
        """
        if self._longest >= self.capacity:
            self._grow()
        flat = self._flat
        index = self._next_index
        for name, values in self._split_obs(obs).items():
            flat[name][index] = np.reshape(values, (self.n_envs, *flat[name].shape[1:]))
        flat["actions"][index] = np.reshape(action, (self.n_envs, self.action_dim))
        flat["rewards"][index] = reward
        flat["episode_ends"][index] = episode_end
        self._env_steps += 1
        self._next_index += self.n_envs
        self._longest += 1
        if episode_end.any():
            ended = np.flatnonzero(episode_end)
            self.finished_steps[ended] = self._env_steps[ended]
            self.n_finished_episodes += len(ended)

    def compute_returns(self) -> None:
        """
        Take the finished episodes out as the batch and compute their returns ``G_t = sum_k gamma^k r_{t+k}``.
        Running episodes move to the front of their columns for the next batch.
        """
        envs = np.flatnonzero(self.finished_steps)
        if len(envs) == 0:
            raise RuntimeError("compute_returns() needs at least one finished episode in the buffer")
        batch = {
            name: np.concatenate([array[: self.finished_steps[env], env] for env in envs])
            for name, array in self._storage.items()
        }
        self._batch = batch
        self.returns = discounted_returns(batch["rewards"], self.gamma, batch["episode_ends"])
        self.episode_lengths = np.diff([0] + [stop for _, stop in episode_bounds(batch["episode_ends"])])
        self.batch_size = len(self.returns)
        # Carry the running episodes over: move each column's unfinished tail to its front.
        for env in envs:
            start, stop = self.finished_steps[env], self.env_steps[env]
            for array in self._storage.values():
                array[: stop - start, env] = array[start:stop, env]
        self.env_steps = self.env_steps - self.finished_steps
        self.finished_steps[:] = 0
        self.n_finished_episodes = 0

    def get(
        self, batch_size: int | None = None
    ) -> Generator[EpisodeRolloutBufferSamples | DictEpisodeRolloutBufferSamples, None, None]:
        """
        Yield the batch made by :meth:`compute_returns`, whole (``batch_size=None``) or in consecutive chunks.

        :param batch_size: Chunk size in steps, or None for the whole batch at once
        """
        assert self.batch_size > 0, "call compute_returns() on a full buffer before get()"
        step = self.batch_size if batch_size is None else batch_size
        for start in range(0, self.batch_size, step):
            yield self._get_samples(np.arange(start, min(start + step, self.batch_size)))

    def _get_samples(  # type: ignore[override]
        self, batch_inds: np.ndarray, env: Any = None
    ) -> EpisodeRolloutBufferSamples | DictEpisodeRolloutBufferSamples:
        whole = len(batch_inds) == self.batch_size
        arrays = {
            name: array if whole else array[batch_inds]
            for name, array in self._batch.items()
            if name not in ("rewards", "episode_ends")
        }
        returns = self.returns if whole else self.returns[batch_inds]
        samples_class = (
            DictEpisodeRolloutBufferSamples if isinstance(self, DictEpisodeRolloutBuffer) else EpisodeRolloutBufferSamples
        )
        return samples_class(
            observations=self._join_obs(arrays),
            actions=self.to_torch(arrays["actions"]),
            returns=self.to_torch(returns.astype(np.float32)),
        )


class DictEpisodeRolloutBuffer(EpisodeRolloutBuffer):
    """:class:`EpisodeRolloutBuffer` for ``Dict`` observation spaces: one storage array per observation key."""

    observation_space: spaces.Dict
    obs_shape: dict[str, tuple[int, ...]]  # type: ignore[assignment]

    def __init__(
        self,
        buffer_size: int,
        observation_space: spaces.Dict,
        action_space: spaces.Space,
        device: th.device | str = "auto",
        gamma: float = 0.99,
        n_envs: int = 1,
        n_episodes: int = 1,
        min_steps: int = 0,
        max_steps: int = 1_000_000,
    ):
        assert isinstance(observation_space, spaces.Dict), "DictEpisodeRolloutBuffer must be used with Dict obs space only"
        super().__init__(buffer_size, observation_space, action_space, device, gamma, n_envs, n_episodes, min_steps, max_steps)

    def _obs_specs(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        return {
            f"observations/{key}": (tuple(shape), _storage_dtype(self.observation_space.spaces[key]))
            for key, shape in self.obs_shape.items()
        }

    def _split_obs(self, obs: Any) -> dict[str, np.ndarray]:
        return {f"observations/{key}": value for key, value in obs.items()}

    def _join_obs(self, arrays: dict[str, np.ndarray]) -> TensorDict:
        return {key: self.to_torch(arrays[f"observations/{key}"]) for key in self.obs_shape}

    @property
    def observations(self) -> dict[str, np.ndarray]:
        """The last batch's observations, one ``(batch_size, *obs_shape[key])`` array per key."""
        return {key: self._batch[f"observations/{key}"] for key in self.obs_shape}
