"""The environment's array helpers (socialaff_sim/environment/arrays.py) against NumPy."""

from __future__ import annotations

import numpy as np

from socialaff_sim.environment.arrays import same_array


def test_same_array_is_numpy_array_equal():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(5, 3))
    cases = [(a, a.copy()), (a, a + 1e-300), (a, a[:4]), (a, a.ravel()), (a, a.astype(np.float32))]
    b = a.copy()
    b[2, 1] = np.nextafter(b[2, 1], np.inf)
    n = a.copy()
    n[0, 0] = np.nan
    cases += [(a, b), (n, n.copy()), (np.zeros((0, 3)), np.zeros((0, 3)))]
    results = []
    for x, y in cases:
        assert same_array(x, y) == np.array_equal(x, y)
        results.append(same_array(x, y))
    assert True in results and False in results
