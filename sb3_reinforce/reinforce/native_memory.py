"""
Give the C heap's free memory back to the operating system (glibc's ``malloc_trim``).

Why REINFORCE needs it: a batch is made of whole episodes, so every update allocates arrays and tensors of a
new size (LunarLander-v3: from about 60 to 1,000 steps an episode). glibc keeps the blocks freed after an
update in its heap, and with sizes that keep changing it reuses them poorly: the resident memory of a
1 env LunarLander-v3 run grew from 412 MiB before ``learn`` to 790 MiB after 1M steps, although the rollout
buffer stayed at 1,024 rows. With ``malloc_trim(0)`` after the updates, the same run stays flat
(``benchmarks/memory.py``, README "Performance"). Nothing is leaked: the memory is free, but not returned.

``malloc_trim`` only releases free pages; it frees nothing that is in use and changes no result. Where it does
not exist (macOS, Windows, musl), :func:`trim_heap` does nothing.
"""

import ctypes
import sys
from collections.abc import Callable

__all__ = ["HeapTrimmer", "trim_heap"]


def _find_malloc_trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(None)  # symbols of the running process, its C library included
    except OSError:  # pragma: no cover - a Linux without dlopen(NULL)
        return None
    malloc_trim = getattr(libc, "malloc_trim", None)  # glibc only
    if malloc_trim is None:
        return None
    malloc_trim.argtypes = [ctypes.c_size_t]
    malloc_trim.restype = ctypes.c_int
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


class HeapTrimmer:
    """
    Call :func:`trim_heap` at most once every ``interval`` environment steps.

    :param interval: Environment steps between two trims, or None to never trim
    """

    def __init__(self, interval: int | None) -> None:
        self.interval = interval
        self.last_trim_step = 0
        self.n_trims = 0

    def step(self, num_timesteps: int) -> None:
        """
        Trim if ``interval`` steps have passed since the last trim.

        :param num_timesteps: The algorithm's step counter
        """
        self.last_trim_step = min(self.last_trim_step, num_timesteps)  # the counter restarts with reset_num_timesteps
        if self.interval is None or num_timesteps - self.last_trim_step < self.interval:
            return
        self.last_trim_step = num_timesteps
        if trim_heap():
            self.n_trims += 1
