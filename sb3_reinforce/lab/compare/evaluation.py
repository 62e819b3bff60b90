"""
A comparison run's evaluation (:class:`Evaluator`): deterministic episodes, then as many with sampled actions, on the
run's own evaluation environment. The deterministic episodes are stepped together (:class:`EpisodeBatch`), giving the episodes
and returns of SB3's ``evaluate_policy`` on the run's one evaluation environment: copy ``i`` gets the generator that
environment had before its ``i``-th reset, and the environment is left as ``evaluate_policy`` leaves it. Returns match
to the bit where the network's outputs do (a batch may round continuous actions differently). Only for environments that
draw random numbers on reset alone (CartPole, Pendulum, MuJoCo, ...), as sampled by :func:`draws_only_on_reset`; others
(LunarLander) use ``evaluate_policy``.
"""

import copy
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor, is_vecenv_wrapped, sync_envs_normalization

__all__ = ["PROBE_STEPS", "EpisodeBatch", "Evaluator", "draws_only_on_reset", "episode_batch"]

#: Random-action steps of the check that an environment draws no random number while it steps
PROBE_STEPS = 200


def _dummy(venv: VecEnv) -> DummyVecEnv:
    """The ``DummyVecEnv`` under a stack of ``VecEnvWrapper`` (``VecNormalize``, ``VecFrameStack``, ...)."""
    while not isinstance(venv, DummyVecEnv):
        venv = venv.venv  # type: ignore[attr-defined]
    return venv


def _generator_state(env: Any) -> dict[str, Any]:
    return env.unwrapped.np_random.bit_generator.state


def draws_only_on_reset(env: Any, steps: int = PROBE_STEPS, seed: int = 0) -> bool:
    """
    Whether a Gymnasium env's generator stays untouched over up to ``steps`` seeded random actions after a reset.

    :param env: The environment (it is reset and stepped)
    :param steps: The most steps taken
    :param seed: The seed of the reset and of the actions
    :return: True where no step drew from the environment's generator
    """
    env.reset(seed=seed)
    env.action_space.seed(seed)
    before = copy.deepcopy(_generator_state(env))
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if _generator_state(env) != before:
            return False
        if terminated or truncated:
            break
    return True


class EpisodeBatch:
    """
    The deterministic episodes of an evaluation on ``n`` copies of the evaluation environment at once.

    :param evaluation_env: The run's one evaluation environment (the sampled-action evaluation goes on with it)
    :param copies: ``n`` environments made as ``evaluation_env`` was (the same wrappers), one per episode
    """

    def __init__(self, evaluation_env: VecEnv, copies: VecEnv) -> None:
        self.evaluation_env = evaluation_env
        self.copies = copies
        self.n_episodes = copies.num_envs
        self._one, self._many = _dummy(evaluation_env), _dummy(copies)
        if self._one.num_envs != 1:
            raise ValueError(f"the evaluation environment must hold one environment, not {self._one.num_envs}")
        self.monitored = is_vecenv_wrapped(copies, VecMonitor) or copies.env_is_wrapped(Monitor)[0]

    def _start_where_the_episodes_start(self) -> None:
        """Give copy ``i`` the generator (or seed) of the ``i``-th reset ``evaluate_policy`` makes on the evaluation env."""
        for i in range(self.n_episodes):
            # SB3's private VecEnv._seeds holds the next reset's seed (stable-baselines3 2.x, bounded below 3.0): no
            # getter
            self._many._seeds[i] = self._one._seeds[0]  # the seed of the very first reset, then None
            self._many.envs[i].unwrapped.np_random = copy.deepcopy(self._one.envs[0].unwrapped.np_random)
            self.evaluation_env.reset()
        self.evaluation_env.reset()  # the reset after the last episode

    def evaluate(self, model: BaseAlgorithm) -> list[float]:
        """
        Play the evaluation's episodes with ``model``'s deterministic actions.

        :param model: The model
        :return: Each episode's return (``Monitor``'s, as ``evaluate_policy`` reads it), in episode order
        """
        self._start_where_the_episodes_start()
        observations = self.copies.reset()
        finished = np.zeros(self.n_episodes, dtype=bool)
        returns = np.zeros(self.n_episodes)
        running = np.zeros(self.n_episodes)
        starts = np.ones(self.n_episodes, dtype=bool)
        states = None
        while not finished.all():
            actions, states = model.predict(
                observations,  # type: ignore[arg-type]
                state=states,
                episode_start=starts,
                deterministic=True,
            )
            observations, rewards, dones, infos = self.copies.step(actions)
            running += rewards
            for i in np.flatnonzero(dones & ~finished):
                if not self.monitored:
                    returns[i], finished[i] = running[i], True
                elif "episode" in infos[i]:  # a lost life (Atari's EpisodicLifeEnv) is not the episode's end
                    returns[i], finished[i] = infos[i]["episode"]["r"], True
            running[dones] = 0.0
            starts = dones
        return [float(value) for value in returns]


def episode_batch(evaluation_env: VecEnv, copies: VecEnv) -> EpisodeBatch | None:
    """
    An :class:`EpisodeBatch` if the env passes :func:`draws_only_on_reset`; else None, and ``copies`` is closed.

    :param evaluation_env: The run's evaluation environment (one environment)
    :param copies: Environments made as ``evaluation_env`` was, one per episode of an evaluation
    """
    if draws_only_on_reset(_dummy(copies).envs[0]):
        return EpisodeBatch(evaluation_env, copies)
    copies.close()
    return None


class Evaluator:
    """
    One evaluation of a comparison run: ``n_episodes`` deterministic episodes, then ``n_episodes`` with sampled
    actions, on the evaluation environment (its ``VecNormalize`` statistics first synchronized with training's).

    :param eval_env: The run's evaluation environment (one environment)
    :param n_episodes: Episodes of each kind
    :param batch: Plays the deterministic episodes side by side, with the same returns (None: ``evaluate_policy``)
    """

    def __init__(self, eval_env: VecEnv, n_episodes: int, batch: EpisodeBatch | None = None) -> None:
        self.eval_env = eval_env
        self.n_episodes = n_episodes
        self.batch = batch

    def evaluate(self, model: BaseAlgorithm, training_env: VecEnv) -> list[float]:
        """
        Evaluate ``model``.

        :param model: The model
        :param training_env: Its training environment (whose normalization statistics the evaluation uses)
        :return: The mean and standard deviation of the deterministic returns, then of the sampled-action returns
        """
        sync_envs_normalization(training_env, self.eval_env)
        results = []
        for deterministic in (True, False):
            if deterministic and self.batch is not None:
                sync_envs_normalization(training_env, self.batch.copies)
                rewards: list[float] = self.batch.evaluate(model)
            else:
                rewards, _ = evaluate_policy(  # type: ignore[assignment]
                    model,
                    self.eval_env,
                    n_eval_episodes=self.n_episodes,
                    deterministic=deterministic,
                    return_episode_rewards=True,
                )
            results += [float(np.mean(rewards)), float(np.std(rewards))]
        return results

    def close(self) -> None:
        """Close the evaluation environments."""
        self.eval_env.close()
        if self.batch is not None:
            self.batch.copies.close()
