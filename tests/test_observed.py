"""The observed interaction synthesis reads: canonicalised once, agent 1 hidden after T0."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.skeletons import N_KEY
from socialaff_sim.errors import ModelError
from socialaff_sim.inference.observed import ObservedInteraction
from socialaff_sim.model.joints import OBJECT


def test_track_is_the_recording_in_the_first_frame_canonical_frame_with_agent1_hidden_after_t0(shake8: Dataset) -> None:
    inter = shake8[2]
    t0 = 7
    obs = ObservedInteraction.of(inter, t0)
    keys = inter.key_joints()  # (T, 2, 5, 3) world
    # The frame: agent 0's base at the origin on the floor, agent 1's base on +x, at the first frame.
    c0 = obs.frame.to_canonical(keys[0, :, 0])
    np.testing.assert_allclose(c0[0, :2], 0.0, atol=1e-9)
    assert c0[1, 0] > 0 and abs(c0[1, 1]) < 1e-9
    # Agent 0 over the whole instance and agent 1 up to T0 are the recording, back in the world frame.
    np.testing.assert_allclose(obs.frame.to_world(obs.track[:, :N_KEY]), keys[:, 0], atol=1e-9)
    np.testing.assert_allclose(obs.frame.to_world(obs.track[:t0, N_KEY : 2 * N_KEY]), keys[:t0, 1], atol=1e-9)
    assert np.isnan(obs.track[t0:, N_KEY : 2 * N_KEY]).all()
    assert np.isfinite(obs.track[t0 - 1, N_KEY : 2 * N_KEY]).all()
    assert np.isnan(obs.track[:, OBJECT]).all() == (inter.object is None)
    assert (obs.n_frames, obs.fps, obs.n_observed, obs.label) == (inter.n_frames, inter.fps, t0, inter.label)


def test_the_value_is_read_only_and_the_interaction_untouched(shake8: Dataset) -> None:
    inter = shake8[3]
    before = inter.joints.copy()
    obs = ObservedInteraction.of(inter, 10)
    with pytest.raises(ValueError, match="read-only"):
        obs.track[0, 0, 0] = 1.0
    np.testing.assert_array_equal(inter.joints, before)


def test_an_instance_not_longer_than_t0_is_refused(shake8: Dataset) -> None:
    inter = shake8[0]
    with pytest.raises(ModelError, match=r"needs more than T0 = \d+ frames"):
        ObservedInteraction.of(inter, inter.n_frames)
    ObservedInteraction.of(inter, inter.n_frames - 1)  # one frame to synthesize is enough
