"""
The process-wide random number generators that training draws from, as JSON-friendly lists.

SB3's ``save`` does not store them, and ``load`` reseeds them from the model's ``seed``: a seeded run that is
saved and loaded would restart its random stream. :class:`~sb3_reinforce.REINFORCE` stores them with the
model and restores them on load, so the resumed run draws the same actions as an uninterrupted one.
"""

import random
from typing import Any

import numpy as np
import torch as th

__all__ = ["get_rng_state", "set_rng_state"]


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
    Restore the generators from :func:`get_rng_state`'s output.

    :param state: What :func:`get_rng_state` returned (possibly through JSON)
    """
    th.set_rng_state(th.tensor(state["torch"], dtype=th.uint8))
    name, keys, pos, has_gauss, cached = state["numpy"]
    np_state = (name, np.asarray(keys, dtype=np.uint32), int(pos), int(has_gauss), float(cached))
    np.random.set_state(np_state)  # noqa: NPY002
    version, internal, gauss = state["random"]
    random.setstate((version, tuple(internal), gauss))
