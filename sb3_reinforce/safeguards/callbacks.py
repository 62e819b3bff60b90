"""
Two SB3 callbacks for long or fragile runs, for REINFORCE or any SB3 algorithm that steps a VecEnv:

- :class:`CheckFinite`: a NaN or an inf in a reward or an observation stops training with an error naming the
  environment, the value and the timestep, before the transition reaches an update. (SB3's ``VecCheckNan`` wrapper
  raises too, without the timestep; REINFORCE itself refuses a non-finite gradient, so without either the weights
  are safe, but the error comes at the update, without saying where the NaN came from.)
- :class:`TrimHeap`: gives the C heap's free pages back to the operating system (glibc ``malloc_trim``) every
  ``interval`` steps. Whole-episode batches allocate a new size at every update, and glibc reuses such blocks
  poorly: the resident memory of a 1-env LunarLander-v3 run grew from 412 MiB to 790 MiB over 1M steps without it,
  and stays flat with it (``benchmarks/memory.py``). It frees nothing in use and changes no result; where the C
  library has no ``malloc_trim`` (macOS, Windows, musl) it does nothing.
"""

import ctypes
import sys
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["CheckFinite", "NonFiniteError", "TrimHeap", "trim_heap"]


class NonFiniteError(FloatingPointError):
    """An environment returned a NaN or an inf, in a reward or an observation."""


def _first_non_finite(values: Any) -> tuple[str, int, np.ndarray] | None:
    """``(key, env index, value)`` of the first environment whose floating-point values (an array, or a dict of
    arrays) hold a NaN or an inf, or None."""
    for key, part in values.items() if isinstance(values, dict) else [("", values)]:
        array = np.asarray(part)
        # Fast path: a sum is finite when every value is (one that overflows only sends us to the exact check).
        if array.dtype.kind != "f" or np.isfinite(array.sum()):
            continue
        bad = ~np.isfinite(array.reshape(len(array), -1)).all(axis=1)
        if bad.any():
            env_idx = int(np.flatnonzero(bad)[0])
            return key, env_idx, array[env_idx]
    return None


class CheckFinite(BaseCallback):
    """
    Raise :class:`NonFiniteError` at the first step whose rewards, observations or (on a truncated episode's
    bootstrap) terminal observations hold a NaN or an inf, naming the environment index, the value and the step.
    """

    def _on_step(self) -> bool:
        found = _first_non_finite(self.locals["new_obs"])
        if found is not None:
            self._raise("observation", *found)
        for env_idx, info in enumerate(self.locals.get("infos", [])):
            terminal_obs = info.get("terminal_observation")
            if terminal_obs is not None:  # before the rewards: a truncated episode's bootstrap reads it into its reward
                is_dict = isinstance(terminal_obs, dict)
                found = _first_non_finite({k: [v] for k, v in terminal_obs.items()} if is_dict else [terminal_obs])
                if found is not None:
                    self._raise("terminal observation", found[0], env_idx, found[2])
        found = _first_non_finite(np.asarray(self.locals["rewards"], dtype=np.float64))
        if found is not None:
            self._raise("reward", *found)
        return True

    def _raise(self, what: str, key: str, env_idx: int, value: np.ndarray) -> None:
        where = f" (key {key!r})" if key else ""
        raise NonFiniteError(
            f"Environment {env_idx} returned a non-finite {what}{where} at timestep {self.num_timesteps}: {value}. "
            "Training stopped before it reached an update (check the environment)."
        )


def _find_malloc_trim() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        malloc_trim = getattr(ctypes.CDLL(None), "malloc_trim", None)  # glibc only
    except OSError:  # pragma: no cover - a Linux without dlopen(NULL)
        return None
    if malloc_trim is not None:
        malloc_trim.argtypes, malloc_trim.restype = [ctypes.c_size_t], ctypes.c_int
    return malloc_trim


_MALLOC_TRIM = _find_malloc_trim()


def trim_heap() -> bool:
    """
    Return the C heap's free pages to the operating system (glibc ``malloc_trim(0)``).

    :return: Whether the C library has ``malloc_trim`` (False: nothing was done)
    """
    if _MALLOC_TRIM is None:
        return False
    _MALLOC_TRIM(0)
    return True


class TrimHeap(BaseCallback):
    """
    Call :func:`trim_heap` at the start of a rollout (the last update's tensors are freed by then), at most once
    every ``interval`` environment steps.

    :param interval: Environment steps between two trims
    """

    def __init__(self, interval: int = 10_000, verbose: int = 0):
        super().__init__(verbose)
        self.interval = interval
        self.last_trim_step = 0
        self.n_trims = 0

    def _on_rollout_start(self) -> None:
        self.last_trim_step = min(self.last_trim_step, self.num_timesteps)  # reset_num_timesteps restarts the count
        if self.num_timesteps - self.last_trim_step >= self.interval:
            self.last_trim_step = self.num_timesteps
            self.n_trims += trim_heap()

    def _on_step(self) -> bool:
        return True
