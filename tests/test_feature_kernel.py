"""The motion features' compiled kernel (kernel="numba", inference/feature_kernel.py): the one-frame row against
FeatureStream's NumPy rows (Anchor.features of the held window), within 1e-12 relative, on random walks with NaN
joints, every group subset and the window still filling; the column layout it writes; a missing numba's error."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import compiled, feature_kernel
from socialaff_sim.inference.reaction_features import (FEATURE_GROUPS, N_FEATURES, RAMP_COLUMN, FeatureConfig,
                                                       FeatureStream, group_columns)

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
T0 = 10


def _walk(rng: np.random.Generator, T: int, *, holes: bool) -> Interaction:
    joints = np.cumsum(rng.normal(0, 0.02, (T, 2, 5, 3)), axis=0) + rng.normal(0, 1, (1, 2, 5, 3))
    valid = np.ones((T, 2, 5), bool)
    if holes:
        valid[rng.random((T, 2, 5)) < 0.15] = False
        valid[:, 0, 3] = False  # never tracked: NaN in every window
    return Interaction("walk", 30.0, joints, KEY_JOINTS, ("p", "q"), valid=valid, instance_id="w")


def test_kernel_columns_are_the_feature_layout() -> None:
    a0, gap, ramp, own, v0 = feature_kernel.COLUMNS
    assert N_FEATURES == v0 and RAMP_COLUMN == gap
    assert list(group_columns(["agent0"])) == list(range(0, a0))
    assert list(group_columns(["gap"])) == list(range(a0, ramp))
    assert list(group_columns(["own_velocity"])) == list(range(ramp, own))
    assert list(group_columns(["agent0_velocity"])) == list(range(own, v0))


@needs_numba
@pytest.mark.parametrize("holes", [False, True])
def test_kernel_rows_equal_numpys_rows(rng: np.random.Generator, holes: bool) -> None:
    inst = _walk(rng, 60, holes=holes)
    subsets = [g for r in range(1, 5) for g in itertools.combinations(FEATURE_GROUPS, r) if "gap" in g]
    for groups in subsets:
        ref, fast = FeatureStream(T0, FeatureConfig()), FeatureStream(T0, FeatureConfig(), "numba")
        for t in range(T0, inst.n_frames):  # from the first frame: the window fills over the first K frames
            view = inst.slice(0, t + 1).hide_agent_after(1, T0)
            a, b = ref.rows(view, t, t + 1, groups), fast.rows(view, t, t + 1, groups)
            assert a.shape == b.shape == (1, N_FEATURES)
            assert np.array_equal(a == 0, b == 0)  # the same columns zero (groups not computed, NaN filled)
            assert np.allclose(b, a, rtol=1e-12, atol=1e-15)
        # Frames past the view (a forecast) and inside it: NumPy's rows (the kernel does one frame just seen).
        assert np.array_equal(fast.rows(view, t, t + 4, groups), ref.rows(view, t, t + 4, groups))
    assert len(feature_kernel.kernels()["feature_row"].signatures) == 1  # compiled once, for the stream's types


def test_numba_features_without_numba_is_a_config_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: False)
    monkeypatch.setattr(compiled, "_ONCE", {})  # as in a new process: nothing compiled yet
    with pytest.raises(ConfigError, match=r"socialaff-sim\[fast\]"):
        FeatureStream(T0, FeatureConfig(), "numba")
    with pytest.raises(ConfigError, match="kernel: expected"):
        FeatureStream(T0, FeatureConfig(), "cython")
