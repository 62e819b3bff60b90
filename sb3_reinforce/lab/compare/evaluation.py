"""
A comparison's deterministic evaluation with all its episodes stepped together, giving the episodes and returns of
SB3's ``evaluate_policy`` on the run's one evaluation environment.

``evaluate_policy`` plays an evaluation's episodes one after another on one environment: a policy call per step of
each episode. :class:`EpisodeBatch` plays them side by side on ``n`` copies of that environment (one policy call per
step for all of them), each copy starting its episode where the one environment would have started it: before each
evaluation, the one environment is reset as many times as ``evaluate_policy`` resets it, and the random generator
it had before its ``i``-th reset is given to copy ``i``, whose reset then draws what that reset drew. The returns come
back in episode order, so their mean and standard deviation are those ``evaluate_policy`` computes, to the bit where
the network's outputs are (a batch and a single observation can round differently in the last bits of a continuous
action), and the one environment is left as ``evaluate_policy`` would have left it: the sampled-action evaluation
that follows on it plays the episodes it always played.

This holds where an environment draws random numbers only when it resets (CartPole, Acrobot, MountainCar, Pendulum,
the MuJoCo tasks), which is checked once, on a copy, by stepping it with random actions: an environment that also
draws while it steps (LunarLander's engine particles) is evaluated by ``evaluate_policy``, one episode after another.
The check is a sample: an environment that drew only in states that 200 random actions do not reach would pass it,
and its batched episodes would then be other episodes than ``evaluate_policy``'s (as fair, not the same).
"""

import copy
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor, is_vecenv_wrapped

__all__ = ["PROBE_STEPS", "EpisodeBatch", "draws_only_on_reset", "episode_batch"]

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
    Whether a Gymnasium environment leaves its random generator untouched while it steps: reset, then up to
    ``steps`` random actions (the action space's own generator, seeded), ending at the episode's end.

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

    :param evaluation_env: The run's evaluation environment (one environment; the sampled-action evaluation goes on
        with it)
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
        """Give copy ``i`` the generator (or pending seed) of the evaluation env's ``i``-th reset; reset it as
        ``evaluate_policy`` would: once at its start, once after each episode."""
        for i in range(self.n_episodes):
            # SB3's VecEnv keeps the seed of its next reset in the private `_seeds` (stable-baselines3 2.x, bounded
            # below 3.0 in pyproject.toml): it has no public getter, and the very first reset is a seeded one
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
    An :class:`EpisodeBatch` of ``copies``, where the environment draws random numbers only when it resets
    (:func:`draws_only_on_reset`, checked on the first copy); else None, and ``copies`` is closed.

    :param evaluation_env: The run's evaluation environment (one environment)
    :param copies: Environments made as ``evaluation_env`` was, one per episode of an evaluation
    """
    if draws_only_on_reset(_dummy(copies).envs[0]):
        return EpisodeBatch(evaluation_env, copies)
    copies.close()
    return None
