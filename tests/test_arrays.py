"""lcs.arrays.unique_sorted: np.unique's values without importing numpy.ma."""

from __future__ import annotations

import numpy as np

from lcs.arrays import unique_sorted


def test_unique_sorted_equals_numpy_unique():
    rng = np.random.default_rng(5)
    for size in (0, 1, 2, 7, 100):
        a = rng.integers(0, 6, size) * 0.25e-6  # repeated times
        assert np.array_equal(unique_sorted(a), np.unique(a))
        assert np.array_equal(unique_sorted(a.reshape(-1, 1)), np.unique(a))
    assert np.array_equal(unique_sorted([3, 1, 3, -0.0, 0.0]), [0.0, 1.0, 3.0])
