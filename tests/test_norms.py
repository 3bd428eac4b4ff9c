"""socialaff_sim._norms: the same values as np.linalg.norm, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim._norms import norm, norms


@pytest.mark.parametrize("shape,axis,keepdims", [((7, 3), 1, False), ((7, 3), -1, True), ((4, 5, 3), 2, False),
                                                 ((4, 5, 3), 0, True), ((13, 40), 1, False), ((6, 4), -1, False)])
def test_norms_equal_numpy_bit_for_bit(shape: tuple[int, ...], axis: int, keepdims: bool) -> None:
    a = np.random.default_rng(3).normal(scale=1e3, size=shape)
    want = np.linalg.norm(a, axis=axis, keepdims=keepdims)
    got = norms(a, axis=axis, keepdims=keepdims)
    assert got.shape == want.shape
    np.testing.assert_array_equal(got, want)


def test_norms_default_axis_is_the_last() -> None:
    a = np.random.default_rng(4).normal(size=(3, 4, 5))
    np.testing.assert_array_equal(norms(a), np.linalg.norm(a, axis=-1))
    assert norms(a).shape == (3, 4)


@pytest.mark.parametrize("n", [2, 3, 6, 40])
def test_norm_equals_numpy_bit_for_bit(n: int) -> None:
    for v in np.random.default_rng(n).normal(scale=50.0, size=(25, n)):
        assert norm(v) == float(np.linalg.norm(v))
    assert norm(np.array([3.0, 4.0])) == 5.0


def test_rows_of_every_scale_equal_numpy_and_the_sum_of_squares() -> None:
    """The IK's and measure_gaps' uses (moved here from test_env_step_cuts with the IK's private copy)."""
    rng = np.random.default_rng(5)
    for shape in [(5, 3), (2, 3), (7, 3)]:
        d = rng.normal(scale=10.0 ** rng.integers(-4, 3), size=shape)
        np.testing.assert_array_equal(norms(d, axis=1), np.linalg.norm(d, axis=1))
        assert np.allclose(norms(d, axis=1), [np.sqrt(sum(v * v for v in row)) for row in d.tolist()], rtol=1e-15)
    diff = rng.normal(size=(4, 6, 3))  # measure_gaps' centre distances
    np.testing.assert_array_equal(norms(diff, axis=2), np.linalg.norm(diff, axis=2))
