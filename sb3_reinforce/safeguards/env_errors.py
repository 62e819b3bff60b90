"""
Clear errors from failing environments, under ``DummyVecEnv`` and ``SubprocVecEnv`` alike.

SB3's ``SubprocVecEnv`` does not send an environment's exception back to the main process: the worker
process dies (its traceback goes to the worker's stderr) and the main process gets a bare ``EOFError`` or
``BrokenPipeError``, with no word of which environment failed or why. ``DummyVecEnv`` re-raises the
original exception, but does not say which of its environments raised it.

:func:`make_safe_vec_env` fixes both without changing SB3: each environment is wrapped in
:class:`CatchEnvErrors` (inside the worker), which turns an exception in ``step`` or ``reset`` into a
message passed back through ``info``, and the vectorized environment is wrapped in :class:`VecEnvErrorCheck`
(in the main process), which raises :class:`EnvError` naming the environment index, the call and the
original exception with its traceback. A worker process that dies (killed, out of memory, segfault) raises
:class:`EnvWorkerDiedError` naming the worker and its exit code, instead of an ``EOFError``.
"""

import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

__all__ = ["CatchEnvErrors", "EnvError", "EnvWorkerDiedError", "VecEnvErrorCheck", "make_safe_vec_env"]

ERROR_KEY = "sb3_reinforce.env_error"
# What a dead worker's pipe raises in the main process
_PIPE_ERRORS = (EOFError, BrokenPipeError, ConnectionResetError)


class EnvError(RuntimeError):
    """
    An environment raised an exception in ``step`` or ``reset``.

    :param env_index: Index of the environment in the vectorized environment
    :param call: The call that failed (``"step"`` or ``"reset"``)
    :param original_type: Name of the original exception's class
    :param message: The original exception's message
    :param original_traceback: The original traceback, as text (it may come from another process)
    """

    def __init__(self, env_index: int, call: str, original_type: str, message: str, original_traceback: str = ""):
        self.env_index = env_index
        self.call = call
        self.original_type = original_type
        self.original_message = message
        self.original_traceback = original_traceback
        text = f"Environment {env_index} raised {original_type} in {call}(): {message}"
        if original_traceback:
            text += f"\n\nOriginal traceback (environment {env_index}):\n{original_traceback}"
        super().__init__(text)


class EnvWorkerDiedError(EnvError):
    """
    The process running an environment of a ``SubprocVecEnv`` died (killed, crashed) during a call.
    ``env_index`` is -1 when the dead worker could not be identified.
    """

    def __init__(self, env_index: int, call: str, original_type: str, message: str, original_traceback: str = ""):
        super().__init__(env_index, call, original_type, message, original_traceback)
        who = f"Environment {env_index}" if env_index >= 0 else "An environment"
        self.args = (f"{who} of the SubprocVecEnv failed in {call}(): {message} (the main process got {original_type})",)


class CatchEnvErrors(gym.Wrapper):
    """
    Report an exception raised by the wrapped environment's ``step`` or ``reset`` through ``info``
    instead of raising it, so that it reaches the main process even from a ``SubprocVecEnv`` worker.
    Use it through :func:`make_safe_vec_env`: without :class:`VecEnvErrorCheck` nobody reads the report.

    ``KeyboardInterrupt`` and ``SystemExit`` are not caught.

    :param env: The environment
    :param env_index: Its index in the vectorized environment (used in the error message)
    """

    def __init__(self, env: gym.Env, env_index: int):
        super().__init__(env)
        self.env_index = env_index

    def _report(self, call: str, exc: Exception) -> dict[str, Any]:
        return {
            ERROR_KEY: {
                "env_index": self.env_index,
                "call": call,
                "original_type": type(exc).__name__,
                "message": str(exc),
                "original_traceback": "".join(traceback.format_exception(exc)),
            }
        }

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        try:
            return self.env.step(action)
        except Exception as exc:
            # A placeholder step that does not end the episode (no automatic reset): the main process raises.
            return self.observation_space.sample(), 0.0, False, False, self._report("step", exc)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        try:
            return self.env.reset(seed=seed, options=options)
        except Exception as exc:
            return self.observation_space.sample(), self._report("reset", exc)


class VecEnvErrorCheck(VecEnvWrapper):
    """
    Raise :class:`EnvError` when an environment wrapped in :class:`CatchEnvErrors` reported an exception,
    and :class:`EnvWorkerDiedError` when a ``SubprocVecEnv`` worker process died.

    An automatic reset that fails at the end of an episode is reported as a failed ``reset``.

    With a ``SubprocVecEnv``, ``step`` waits for the workers' answers while watching that their processes
    are alive (every ``poll_interval`` seconds), so a worker that dies is reported even when its pipe
    does not close: with the ``fork`` start method the other workers inherit its end of the pipe and
    SB3's ``step_wait`` would wait forever. ``timeout`` also bounds the wait for a live but stuck worker.

    :param venv: The vectorized environment (its environments wrapped in :class:`CatchEnvErrors`)
    :param timeout: Most seconds to wait for the answer of a ``SubprocVecEnv`` worker to ``step``,
        or None to wait as long as the worker lives
    :param poll_interval: How often (seconds) to check that the ``SubprocVecEnv`` workers are alive
    """

    def __init__(self, venv: VecEnv, timeout: float | None = None, poll_interval: float = 0.1):
        super().__init__(venv)
        self.timeout = timeout
        self.poll_interval = poll_interval

    def _wait_for_workers(self, call: str) -> None:
        remotes = getattr(self.venv, "remotes", None)
        processes = getattr(self.venv, "processes", None)
        if remotes is None or processes is None:
            return
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        for idx, (remote, process) in enumerate(zip(remotes, processes, strict=True)):
            while not remote.poll(self.poll_interval):
                if not process.is_alive():
                    raise self._worker_died(call, EOFError(f"worker {idx} is dead"))
                if deadline is not None and time.monotonic() > deadline:
                    self._close_broken()
                    raise EnvWorkerDiedError(
                        idx, call, "TimeoutError", f"its worker process did not answer within {self.timeout} s (terminated)"
                    )

    def _raise_reported(self, infos: Sequence[dict[str, Any]], reset_call: bool) -> None:
        for info in infos:
            if info and ERROR_KEY in info:
                report = info[ERROR_KEY]
                raise EnvError(
                    report["env_index"],
                    report["call"] if not reset_call else "reset",
                    report["original_type"],
                    report["message"],
                    report["original_traceback"],
                )

    def _worker_died(self, call: str, exc: BaseException) -> EnvWorkerDiedError:
        processes = getattr(self.venv, "processes", [])
        dead = [idx for idx, process in enumerate(processes) if not process.is_alive()]
        if not dead:  # the pipe broke first: give the dying process a moment to be reaped
            for process in processes:
                process.join(timeout=0.2)
            dead = [idx for idx, process in enumerate(processes) if not process.is_alive()]
        self._close_broken()
        if dead:
            idx = dead[0]
            message = f"its worker process (pid {processes[idx].pid}) died with exit code {processes[idx].exitcode}"
            if processes[idx].exitcode is not None and processes[idx].exitcode < 0:
                message += f" (killed by signal {-processes[idx].exitcode})"
            return EnvWorkerDiedError(idx, call, type(exc).__name__, message)
        return EnvWorkerDiedError(-1, call, type(exc).__name__, f"a worker process stopped answering ({exc!r})")

    def _close_broken(self) -> None:
        # SubprocVecEnv.close() would wait on the dead pipe: end the other workers and mark it closed.
        for process in getattr(self.venv, "processes", []):
            if process.is_alive():
                process.terminate()
            process.join(timeout=5.0)
        for remote in getattr(self.venv, "remotes", []):
            remote.close()
        self.venv.closed = True  # type: ignore[attr-defined]

    def reset(self) -> VecEnvObs:
        dead = [idx for idx, process in enumerate(getattr(self.venv, "processes", [])) if not process.is_alive()]
        if dead:
            raise self._worker_died("reset", EOFError(f"worker {dead[0]} is dead"))
        try:
            obs = self.venv.reset()
        except _PIPE_ERRORS as exc:
            raise self._worker_died("reset", exc) from exc
        self._raise_reported(self.venv.reset_infos, reset_call=True)
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        try:
            self.venv.step_async(actions)
        except _PIPE_ERRORS as exc:
            raise self._worker_died("step", exc) from exc

    def step_wait(self) -> VecEnvStepReturn:
        self._wait_for_workers("step")
        try:
            obs, rewards, dones, infos = self.venv.step_wait()
        except _PIPE_ERRORS as exc:
            raise self._worker_died("step", exc) from exc
        self._raise_reported(infos, reset_call=False)
        self._raise_reported(self.venv.reset_infos, reset_call=True)
        return obs, rewards, dones, infos

    def close(self) -> None:
        if getattr(self.venv, "closed", False):
            return
        try:
            self.venv.close()
        except _PIPE_ERRORS:
            self._close_broken()


def make_safe_vec_env(
    env_fns: Sequence[Callable[[], gym.Env]],
    vec_env_cls: type[DummyVecEnv] | type[SubprocVecEnv] = DummyVecEnv,
    vec_env_kwargs: dict[str, Any] | None = None,
    timeout: float | None = None,
) -> VecEnv:
    """
    Build a vectorized environment whose failures raise :class:`EnvError` (which environment, which call,
    the original exception and traceback) or :class:`EnvWorkerDiedError`, under both ``DummyVecEnv``
    and ``SubprocVecEnv``.

    :param env_fns: One function per environment, each returning a fresh ``gym.Env`` (as for SB3's VecEnvs;
        wrap them in ``Monitor`` yourself to get episode statistics)
    :param vec_env_cls: ``DummyVecEnv`` or ``SubprocVecEnv``
    :param vec_env_kwargs: Keyword arguments for ``vec_env_cls`` (e.g. ``start_method``)
    :param timeout: See :class:`VecEnvErrorCheck`
    :return: The wrapped vectorized environment
    """
    wrapped = [_CatchingFactory(env_fn, idx) for idx, env_fn in enumerate(env_fns)]
    try:
        venv = vec_env_cls(wrapped, **(vec_env_kwargs or {}))  # type: ignore[arg-type]
    except _PIPE_ERRORS as exc:
        # SubprocVecEnv asks worker 0 for the spaces: its pipe closes if an env_fn raised in a worker.
        raise EnvWorkerDiedError(
            -1, "make_env", type(exc).__name__, "a worker process died while creating its environment (see its stderr)"
        ) from exc
    return VecEnvErrorCheck(venv, timeout=timeout)


class _CatchingFactory:
    # A class, not a closure, so that it pickles for SubprocVecEnv's workers.
    def __init__(self, env_fn: Callable[[], gym.Env], env_index: int):
        self.env_fn = env_fn
        self.env_index = env_index

    def __call__(self) -> gym.Env:
        return CatchEnvErrors(self.env_fn(), self.env_index)
