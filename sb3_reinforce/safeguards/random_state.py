"""
Save and load a model with the random generators' state, so that a seeded run that is saved and loaded draws what
an uninterrupted run draws (SB3's ``load`` reseeds the generators from the model's ``seed`` instead, which
restarts its random stream). For REINFORCE or any SB3 algorithm; the file is SB3's ``.zip`` with one more entry.
"""

import io
import pathlib
import random
from typing import Any, TypeVar

import numpy as np
import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm

__all__ = ["get_rng_state", "load_with_random_state", "save_with_random_state", "set_rng_state"]

SelfAlgorithm = TypeVar("SelfAlgorithm", bound=BaseAlgorithm)
_ATTRIBUTE = "_rng_state"  # the model's attribute SB3 saves it under (older REINFORCE files have it too)


def get_rng_state() -> dict[str, Any]:
    """
    :return: The states of the torch (CPU), numpy (global) and ``random`` generators, made of lists and numbers only
    """
    np_state = np.random.get_state(legacy=True)  # noqa: NPY002  (the global generator is the one to save)
    assert isinstance(np_state, tuple)
    version, internal, gauss = random.getstate()
    return {
        "torch": th.get_rng_state().tolist(),
        "numpy": [np_state[0], np_state[1].tolist(), *(x.item() if hasattr(x, "item") else x for x in np_state[2:])],
        "random": [version, list(internal), gauss],
    }


def set_rng_state(state: dict[str, Any]) -> None:
    """
    Restore the generators from :func:`get_rng_state`'s output (possibly through JSON).

    :param state: What :func:`get_rng_state` returned
    """
    th.set_rng_state(th.tensor(state["torch"], dtype=th.uint8))
    name, keys, pos, has_gauss, cached = state["numpy"]
    np.random.set_state((name, np.asarray(keys, dtype=np.uint32), int(pos), int(has_gauss), float(cached)))  # noqa: NPY002
    version, internal, gauss = state["random"]
    random.setstate((version, tuple(internal), gauss))


def save_with_random_state(model: BaseAlgorithm, path: str | pathlib.Path | io.BufferedIOBase, **kwargs: Any) -> None:
    """
    ``model.save(path)``, with the states of the torch, numpy and ``random`` generators in the file.

    :param model: The model
    :param path: Where to save it
    :param kwargs: ``exclude`` / ``include``, as SB3's ``save``
    """
    setattr(model, _ATTRIBUTE, get_rng_state())
    try:
        model.save(path, **kwargs)
    finally:
        delattr(model, _ATTRIBUTE)


def load_with_random_state(
    algorithm: type[SelfAlgorithm], path: str | pathlib.Path | io.BufferedIOBase, **kwargs: Any
) -> SelfAlgorithm:
    """
    ``algorithm.load(path, **kwargs)``, then, for a model with a ``seed``, the generators restored to their state
    at save time (instead of reseeded from ``seed``).

    :param algorithm: The algorithm class (``REINFORCE``, ``PPO``, ...)
    :param path: A file written by :func:`save_with_random_state`
    :param kwargs: SB3's ``load`` arguments (``env``, ``device``, ``custom_objects``, ...)
    :return: The model
    """
    model = algorithm.load(path, **kwargs)
    state = model.__dict__.pop(_ATTRIBUTE, None)
    if state is not None and model.seed is not None:
        set_rng_state(state)
    return model
