"""
Saving and loading as SB3 does, plus two guarantees: a damaged file gives a clear error before SB3 reads it, and a
seeded model that is saved and loaded continues its random stream (SB3 reseeds the generators from ``seed``).
"""

import io
import pathlib
from typing import Any

import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm, SelfBaseAlgorithm
from stable_baselines3.common.type_aliases import GymEnv

from sb3_reinforce.reinforce.model_file import check_model_file
from sb3_reinforce.reinforce.rng import get_rng_state, set_rng_state

__all__ = ["SaveWithRandomState"]


class SaveWithRandomState(BaseAlgorithm):
    """
    SB3's ``save``/``load`` with the states of the torch, numpy and ``random`` generators stored in the file, and
    the file's integrity checked before loading. A mixin: put it before SB3's algorithm class.
    """

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
        see :func:`sb3_reinforce.load_weights` for a format that does not).

        The file is checked first: a truncated or corrupted file raises
        :class:`~sb3_reinforce.CorruptModelFileError`. For a model with a ``seed``, the random generators are restored
        to their state at save time (instead of being reseeded from ``seed``, as SB3 does).

        Takes SB3's ``BaseAlgorithm.load`` arguments.
        """
        check_model_file(path)
        model = super().load(path, env, device, custom_objects, print_system_info, force_reset, **kwargs)
        rng_state = model.__dict__.pop("_rng_state", None)
        if rng_state is not None and model.seed is not None:
            set_rng_state(rng_state)
        return model
