"""The full-episode rollout buffer: whole episodes, carried-over running episodes, bounded memory."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE, DictEpisodeRolloutBuffer, EpisodeRolloutBuffer, RolloutLimitError
from tests.envs import CountingEnv


class RecordBatches(BaseCallback):
    """Record every observation the envs emitted and every transition each batch trained on."""

    def __init__(self) -> None:
        super().__init__()
        self.batch_obs: list[np.ndarray] = []
        self.batch_returns: list[np.ndarray] = []
        self.batch_lengths: list[np.ndarray] = []
        self.acted_on: list[np.ndarray] = []

    def _on_training_start(self) -> None:
        self.acted_on.append(np.array(self.model._last_obs))

    def _on_step(self) -> bool:
        self.acted_on.append(np.array(self.locals["new_obs"]))
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        self.batch_obs.append(buffer._batch["observations"].copy())
        self.batch_returns.append(buffer.returns.copy())
        self.batch_lengths.append(buffer.episode_lengths.copy())


@pytest.mark.parametrize("n_envs", [1, 4])
@pytest.mark.parametrize("n_episodes", [1, 3])
def test_no_transition_lost_or_used_twice(n_envs: int, n_episodes: int) -> None:
    lengths = [(3, 5, 2), (7,), (1, 4), (6, 2, 9)]
    env = DummyVecEnv([lambda i=i: CountingEnv(i, lengths[i]) for i in range(n_envs)])
    model = REINFORCE("MlpPolicy", env, n_episodes=n_episodes, seed=0)
    recorder = RecordBatches()
    model.learn(300, callback=recorder)

    trained = np.concatenate(recorder.batch_obs)
    keys = {(int(e), int(s)) for e, s, _ in trained}
    assert len(keys) == len(trained), "a transition was used twice"
    # Every observation acted upon is in a batch, except those of episodes still running in the buffer.
    acted = np.concatenate(recorder.acted_on[:-1])  # the last new_obs has not been acted upon yet
    still_running = model.rollout_buffer.size()
    assert len(acted) == len(trained) + still_running
    assert keys <= {(int(e), int(s)) for e, s, _ in acted}
    assert model.num_timesteps == len(acted)
    # n_episodes counts per environment, as SB3's n_steps: a batch holds n_episodes * n_envs episodes or more
    assert recorder.batch_lengths, "no batch was trained"
    for lengths_ in recorder.batch_lengths:
        assert len(lengths_) >= n_episodes * n_envs
    assert min(len(lengths_) for lengths_ in recorder.batch_lengths) < n_episodes * (n_envs + 1)
    if n_envs == 1:
        assert still_running == 0, "with one env a batch ends exactly on an episode end"


@pytest.mark.parametrize("truncate", [False, True])
def test_buffer_returns_match_closed_form(truncate: bool) -> None:
    """As SB3's test_gae: returns recomputed independently of the buffer, from what the env emitted."""
    gamma = 0.9
    env = DummyVecEnv([lambda i=i: CountingEnv(i, (4, 2, 6), truncate=truncate) for i in range(3)])
    model = REINFORCE("MlpPolicy", env, gamma=gamma, n_episodes=2, seed=1)  # no baseline: truncation = terminal
    recorder = RecordBatches()
    model.learn(200, callback=recorder)
    for obs, returns, lengths in zip(recorder.batch_obs, recorder.batch_returns, recorder.batch_lengths, strict=True):
        assert lengths.sum() == len(obs)
        start = 0
        for length in lengths:
            steps = obs[start : start + length, 2]
            np.testing.assert_array_equal(steps, np.arange(length), err_msg="an episode was cut or reordered")
            # reward at step t is t + 1: G_t = sum_{k=t}^{L-1} gamma^(k-t) (k + 1)
            expected = [sum(gamma ** (k - t) * (k + 1) for k in range(t, length)) for t in range(length)]
            np.testing.assert_allclose(returns[start : start + length], expected, rtol=1e-6)
            start += length


def _box_buffer(n_envs: int = 2, **kwargs: int) -> EpisodeRolloutBuffer:
    return EpisodeRolloutBuffer(
        4,
        spaces.Box(-1, 1, (3,)),
        spaces.Discrete(2),
        device="cpu",
        n_envs=n_envs,
        **kwargs,  # type: ignore[arg-type]
    )


def test_capacity_grows_and_is_reused() -> None:
    buffer = _box_buffer(n_envs=2, n_episodes=2)
    not_done = np.zeros(2, dtype=bool)
    for _ in range(3):  # three batches of two 10-step episodes
        for t in range(10):
            buffer.add(np.ones((2, 3)), np.zeros(2), np.ones(2), not_done if t < 9 else ~not_done)
        assert buffer.is_full
        buffer.compute_returns()
        assert buffer.batch_size == 20 and list(buffer.episode_lengths) == [10, 10]
        assert buffer.size() == 0
    assert buffer.capacity == 16, "doubling from 4 to the longest column, then kept"


def test_memory_is_proportional_to_batch_not_training_length() -> None:
    env = DummyVecEnv([lambda: CountingEnv(0, (5,))])
    model = REINFORCE("MlpPolicy", env, n_episodes=2, seed=0)
    model.learn(1_000)
    capacity = model.rollout_buffer.capacity
    model.learn(20_000, reset_num_timesteps=False)
    assert model.rollout_buffer.capacity == capacity


def test_endless_episode_hits_clear_error() -> None:
    # Warned of once an episode has run for a tenth of the limit (issue 62: not a silent million steps), then the
    # error names the constructor's argument
    env = DummyVecEnv([lambda: CountingEnv(0, (10**9,))])
    model = REINFORCE("MlpPolicy", env, max_rollout_steps=500, seed=0)
    with (
        pytest.warns(UserWarning, match="Environment 0 of 1 has run one episode for 50 steps") as warned,
        pytest.raises(RolloutLimitError, match=r"its limit, max_rollout_steps=500, .* give the environment a time limit"),
    ):
        model.learn(10_000)
    assert model.rollout_buffer.size() <= 500
    assert "max_rollout_steps=500 transitions" in str(warned[0].message)


def test_long_episodes_of_a_named_env_are_warned_about_once_per_length() -> None:
    # A registered env without a time limit is named; episodes that end are never warned about
    env = DummyVecEnv([lambda: gym.make("CartPole-v1", max_episode_steps=-1)])  # -1: without its TimeLimit
    assert env.env_is_wrapped(gym.wrappers.TimeLimit) == [False]
    model = REINFORCE("MlpPolicy", env, max_rollout_steps=100, seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.learn(300)  # CartPole's untrained episodes last about 10-40 steps: some reach 10
    messages = [str(w.message) for w in caught if "has run one episode" in str(w.message)]
    assert messages and all(m.startswith("CartPole-v1 (environment 0 of 1)") for m in messages)
    quiet = REINFORCE("MlpPolicy", DummyVecEnv([lambda: CountingEnv(0, (5,))]), max_rollout_steps=100, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        quiet.learn(300)  # episodes of 5 steps, under the tenth (10)


def test_min_steps_extends_batch_with_whole_episodes() -> None:
    env = DummyVecEnv([lambda: CountingEnv(0, (3,))])
    model = REINFORCE("MlpPolicy", env, n_episodes=1, min_steps=10, seed=0)
    recorder = RecordBatches()
    model.learn(60, callback=recorder)
    for lengths in recorder.batch_lengths:
        assert lengths.sum() >= 10 and (lengths == 3).all()


def test_dict_buffer_roundtrip() -> None:
    obs_space = spaces.Dict({"img": spaces.Box(0, 255, (4, 4, 1), dtype=np.uint8), "vec": spaces.Box(-1, 1, (2,))})
    buffer = DictEpisodeRolloutBuffer(2, obs_space, spaces.Box(-1, 1, (2,)), device="cpu", n_envs=2)
    for t in range(5):
        obs = {"img": np.full((2, 4, 4, 1), t, dtype=np.uint8), "vec": np.full((2, 2), t, dtype=np.float32)}
        buffer.add(obs, np.zeros((2, 2)), np.ones(2), np.array([t == 2, t == 4]))
    assert buffer.is_full
    buffer.compute_returns()
    batch = next(buffer.get())
    assert batch.observations["img"].dtype.is_floating_point is False, "images are stored as uint8"
    assert batch.observations["img"].shape == (8, 4, 4, 1)
    assert [int(x) for x in batch.observations["vec"][:, 0]] == [0, 1, 2, 0, 1, 2, 3, 4]
    assert batch.returns.shape == (8,)


class ReadBufferAsA2CCallbacksDo(BaseCallback):
    """Reads the rollout buffer under SB3's names at the end of each rollout, as callbacks written for A2C/PPO do."""

    NAMES = ("observations", "actions", "rewards", "returns", "episode_starts")

    def __init__(self) -> None:
        super().__init__()
        self.batches: list[dict[str, np.ndarray]] = []
        self.episode_lengths: list[np.ndarray] = []

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        self.batches.append({name: np.array(getattr(buffer, name)) for name in self.NAMES})
        self.episode_lengths.append(buffer.episode_lengths.copy())

    def _on_step(self) -> bool:
        return True


@pytest.mark.parametrize("n_envs", [1, 3])
def test_last_batch_under_sb3_names(n_envs: int) -> None:
    """``observations``, ``actions``, ``rewards``, ``returns``, ``episode_starts``: the last batch, one row a step."""
    gamma = 0.9
    env = DummyVecEnv([lambda i=i: CountingEnv(i, (4, 2, 6)) for i in range(n_envs)])
    model = REINFORCE("MlpPolicy", env, gamma=gamma, n_episodes=2, seed=0)
    for name in ReadBufferAsA2CCallbacksDo.NAMES:  # readable before the first batch: empty
        assert len(getattr(model.rollout_buffer, name)) == 0, name
    reader = ReadBufferAsA2CCallbacksDo()
    model.learn(100, callback=reader)
    assert reader.batches, "no batch was trained"
    for batch, lengths in zip(reader.batches, reader.episode_lengths, strict=True):
        size = int(lengths.sum())
        assert batch["observations"].shape == (size, 3)
        assert batch["actions"].shape == (size, 1)  # (batch_size, action_dim), Discrete: one column
        assert batch["rewards"].shape == batch["returns"].shape == batch["episode_starts"].shape == (size,)
        starts = np.flatnonzero(batch["episode_starts"])
        np.testing.assert_array_equal(starts, np.cumsum(lengths) - lengths)
        for start, length in zip(starts, lengths, strict=True):
            steps = batch["observations"][start : start + length, 2]
            np.testing.assert_array_equal(steps, np.arange(length))
            np.testing.assert_array_equal(batch["rewards"][start : start + length], steps + 1)  # reward at step t: t + 1
            expected = [sum(gamma ** (k - t) * (k + 1) for k in range(t, length)) for t in range(length)]
            np.testing.assert_allclose(batch["returns"][start : start + length], expected, rtol=1e-6)
    # The attributes are the batch that train() used: what get() yields
    last = reader.batches[-1]
    samples = next(model.rollout_buffer.get())
    np.testing.assert_array_equal(samples.observations.numpy(), last["observations"])
    np.testing.assert_array_equal(samples.actions.numpy(), last["actions"])
    np.testing.assert_allclose(samples.returns.numpy(), last["returns"], rtol=1e-6)


def test_last_batch_under_sb3_names_dict() -> None:
    obs_space = spaces.Dict({"img": spaces.Box(0, 255, (4, 4, 1), dtype=np.uint8), "vec": spaces.Box(-1, 1, (2,))})
    buffer = DictEpisodeRolloutBuffer(2, obs_space, spaces.Box(-1, 1, (2,)), device="cpu", n_envs=2)
    assert buffer.observations["img"].shape == (0, 4, 4, 1) and buffer.actions.shape == (0, 2)
    for t in range(5):
        obs = {"img": np.full((2, 4, 4, 1), t, dtype=np.uint8), "vec": np.full((2, 2), t, dtype=np.float32)}
        buffer.add(obs, np.full((2, 2), t), np.ones(2), np.array([t == 2, t == 4]))
    buffer.compute_returns()
    assert buffer.observations["img"].shape == (8, 4, 4, 1) and buffer.observations["img"].dtype == np.uint8
    assert list(buffer.observations["vec"][:, 0]) == [0, 1, 2, 0, 1, 2, 3, 4]
    assert buffer.actions.shape == (8, 2) and list(buffer.actions[:, 0]) == [0, 1, 2, 0, 1, 2, 3, 4]
    assert list(buffer.episode_starts) == [1, 0, 0, 1, 0, 0, 0, 0]
    assert buffer.rewards.shape == buffer.returns.shape == (8,)


def test_sb3_rollout_buffer_is_refused() -> None:
    # SB3's fixed-length RolloutBuffer cannot hold whole episodes: a clear error, not one from deep inside
    from stable_baselines3.common.buffers import RolloutBuffer

    with pytest.raises(TypeError, match=r"rollout_buffer_class must be an EpisodeRolloutBuffer"):
        REINFORCE("MlpPolicy", "CartPole-v1", rollout_buffer_class=RolloutBuffer)  # type: ignore[arg-type]
