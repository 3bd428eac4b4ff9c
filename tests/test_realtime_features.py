"""The motion features' per-frame shortcuts (issue 24, real-time speed) against what they replace, bitwise: the
window's slope by one ``np.dot`` against ``velocity_estimate`` (``np.tensordot``), and a stream's rows with the new
frames' key joints gathered at once against the per-key-joint loop, on a layout with every key joint and with
tracking gaps, one frame per call and several."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import N_KEY
from socialaff_sim.inference import reaction_features
from socialaff_sim.inference.reaction_features import FeatureConfig, FeatureStream, _window_slope, velocity_estimate

from test_ridge_baseline import make_instance

T0 = 10


def test_window_slope_equals_velocity_estimate(rng: np.random.Generator) -> None:
    for i in range(3000):
        k = int(rng.integers(2, 9))
        x = rng.normal(size=(k, N_KEY, 3)) * rng.uniform(0.01, 10.0)
        if i % 3 == 0:
            x[rng.random(x.shape) < 0.2] = np.nan
        assert np.array_equal(_window_slope(x), velocity_estimate(x), equal_nan=True)


def _old_consume(self: FeatureStream, view: Interaction) -> None:
    new = slice(self._seen, view.n_frames)
    keys = view.layout.key_joints(view.joints[new, 0])
    valid = np.zeros((keys.shape[0], N_KEY), dtype=bool)
    for k, idx in enumerate(view.layout.key_indices):
        if idx is not None:
            valid[:, k] = np.asarray(view.valid)[new, 0, idx]
    for cur, ok in zip(keys, valid, strict=True):
        self._last = np.where(ok[:, None] & np.isfinite(cur), cur, self._last)
        self._window.append(self._last)
    self._window = self._window[-self.config.window:]
    self._seen = view.n_frames


def _rows(inst: Interaction, step: int) -> np.ndarray:
    stream = FeatureStream(T0, FeatureConfig())
    view_src = inst.hide_agent_after(1, T0)
    return np.concatenate([stream.rows(view_src.slice(0, t + 1), t, t + step) for t in range(T0, inst.n_frames, step)])


@pytest.mark.parametrize("step", [1, 3])
def test_stream_rows_equal_the_per_key_joint_loop(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch, step: int) -> None:
    inst = make_instance(rng, "follow", T=40)
    valid = np.array(inst.valid, copy=True)
    valid[12:17, 0, 1] = False  # a wrist's tracking gap: held
    gappy = inst.replace(valid=valid)
    assert None not in inst.layout.key_indices
    new = [_rows(x, step) for x in (inst, gappy)]
    monkeypatch.setattr(FeatureStream, "_consume", _old_consume)
    monkeypatch.setattr(reaction_features, "_window_slope", velocity_estimate)
    old = [_rows(x, step) for x in (inst, gappy)]
    for a, b in zip(new, old, strict=True):
        assert np.array_equal(a, b)
    assert not np.array_equal(new[0], new[1])  # the gap is seen
