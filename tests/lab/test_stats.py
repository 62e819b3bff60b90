"""Tianshou's benchmark metric (best_mean_over_seeds): hand-computed cases and its properties."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sb3_reinforce.lab.stats import best_mean_over_seeds


def test_best_mean_over_seeds_hand_computed() -> None:
    # Two seeds, three evaluation points: the mean curve is 1.5, 3.5, 2.5, its best point the second
    curves = [[1.0, 3.0, 4.0], [2.0, 4.0, 1.0]]
    best, std, index = best_mean_over_seeds(curves)
    assert (best, std, index) == (3.5, 0.5, 1)
    # Not the best seed's best point (4.0), nor the mean of each seed's best (4.0): the best of the mean curve
    assert best < np.mean(np.max(curves, axis=1))


def test_best_mean_over_seeds_bad_input() -> None:
    for bad in ([], [1.0, 2.0], [[1.0, np.nan]]):
        with pytest.raises(ValueError, match="best_mean_over_seeds"):
            best_mean_over_seeds(bad)


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)


@given(arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(1, 30)), elements=finite))
def test_best_mean_over_seeds_properties(curves: np.ndarray) -> None:
    best, std, index = best_mean_over_seeds(curves)
    means = curves.mean(axis=0)
    # It is a point of the mean curve, none higher, and the first of the highest
    assert best == pytest.approx(means[index]) and np.all(means <= best + 1e-9 * (1 + abs(best)))
    assert not np.any(means[:index] >= best)
    # Between the final mean and the best single evaluation; its std is the seeds' spread at that point
    assert means[-1] <= best + 1e-6 and best <= curves.max() + 1e-6
    assert std == pytest.approx(curves[:, index].std())
    # The seeds' order does not matter
    assert best_mean_over_seeds(curves[::-1])[0] == pytest.approx(best)
