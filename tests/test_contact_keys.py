"""Contact keyframes: learning them against a frame-by-frame reference, and the synthesizer's pull toward them."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.contact_keys import ContactKeys, fit_contact_keys
from socialaff_sim.model.joints import JOINT_NAMES, N_JOINTS, instance_frame

RW0, LW0, RW1, LW1, BASE1 = (JOINT_NAMES.index(n) for n in ("agent0.right_wrist", "agent0.left_wrist",
                                                          "agent1.right_wrist", "agent1.left_wrist", "agent1.base"))


def _strike_tracks(rng: np.random.Generator, n: int, contact_at: list[int], touch: float, *, end_touch: bool = False):
    """n tracks of 30 frames parsed (0, 10, 0), (10, 22, 1), (22, 30, 0): in type 1 agent 1's right wrist
    comes from 1 m away to ``touch`` metres from agent 0's right wrist at frame ``10 + contact_at[i]``
    and goes back (or stays, ``end_touch``)."""
    tracks, spans = [], []
    for i in range(n):
        x = rng.normal(scale=0.05, size=(30, N_JOINTS, 3))
        x[:, RW0] += [0.0, 0.0, 1.5]
        x[:, LW0] += [0.0, 2.0, 1.0]  # agent 0's other wrist, far from everything
        c = 10 + contact_at[i]
        gap = np.abs(np.arange(30) - c).astype(float)
        if end_touch:
            gap[c:] = 0.0
        dist = np.minimum(touch + 0.15 * gap, 1.0)
        x[:, RW1] = x[:, RW0] + dist[:, None] * np.array([1.0, 0.0, 0.0])
        x[:, LW1] += [1.0, -2.0, 1.0]
        tracks.append(x)
        spans.append([(0, 10, 0), (10, 22, 1), (22, 30, 0)])
    return tracks, spans


def _reference(tracks, spans, s: int, j: int, mates: list[int]):  # noqa: ANN202
    """Mean phase, commonest nearest mate, mean offset to it, mean closest distance, the smaller of the
    mean distances at the intervals' first and last frames, and the mate's mean position relative to
    agent 0's base at the touch with its RMS spread: frame by frame."""
    phases, near, offs, closest, ends, poses = [], [], [], [], [], []
    for x, sp in zip(tracks, spans, strict=True):
        for a, b, lab in sp:
            if lab != s:
                continue
            best = (np.inf, -1, -1)
            for f in range(a, b):
                for m in mates:
                    d = float(np.linalg.norm(x[f, j] - x[f, m]))
                    if d < best[0]:
                        best = (d, f, m)
            d, f, m = best
            phases.append((f - a) / (b - 1 - a))
            near.append(m)
            offs.append(x[f, j] - x[f, m])
            poses.append(x[f, m] - x[f, 0])
            closest.append(d)
            ends.append([min(np.linalg.norm(x[e, j] - x[e, m2]) for m2 in mates) for e in (a, b - 1)])
    m = max(set(near), key=near.count)
    off = np.mean([o for o, k in zip(offs, near, strict=True) if k == m], axis=0)
    at = [p for p, k in zip(poses, near, strict=True) if k == m]
    pose = np.mean(at, axis=0)
    spread = float(np.sqrt(np.mean([np.sum((p - pose) ** 2) for p in at])))
    return float(np.mean(phases)), m, off, float(np.mean(closest)), float(np.min(np.mean(ends, axis=0))), pose, spread


def test_keyframe_matches_a_frame_by_frame_reference(rng: np.random.Generator) -> None:
    contact_at = [4, 5, 6, 5, 7]
    tracks, spans = _strike_tracks(rng, 5, contact_at, 0.08)
    grouping = np.zeros((2, N_JOINTS), np.int64)
    grouping[1, [RW0, LW0, RW1]] = 1
    available = np.ones(N_JOINTS, bool)
    keys = fit_contact_keys(grouping, spans, tracks, available, radius=0.2)
    phase, mate, offset, closest, _, pose, spread = _reference(tracks, spans, 1, RW1, [RW0, LW0])
    assert closest < 0.2
    got = keys.of_type(1)
    assert len(got) == 1 and not keys.of_type(0) and [k.joint for k in keys.all()] == [RW1]
    j, m, ph, off, pos, spr = got[0]
    assert (j, m) == (RW1, mate) == (RW1, RW0)
    np.testing.assert_allclose(ph, phase, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ph, np.mean(contact_at) / 11, rtol=0, atol=0.02)  # the planted frames
    np.testing.assert_allclose(off, offset, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pos, pose, rtol=0, atol=1e-12)
    np.testing.assert_allclose(spr, max(spread, 0.1), rtol=0, atol=1e-12)  # floored at radius / 2
    assert keys.mate[1, RW1 - 5] == RW0 and np.isnan(keys.phase[1, LW1 - 5]) and keys.mate[1, LW1 - 5] == -1


@pytest.mark.parametrize("case", ["far", "touch_at_end", "not_grouped", "base_only"])
def test_no_keyframe_without_a_released_contact_of_a_grouped_wrist(rng: np.random.Generator, case: str) -> None:
    tracks, spans = _strike_tracks(rng, 4, [5, 5, 6, 4], 0.35 if case == "far" else 0.08, end_touch=case == "touch_at_end")
    grouping = np.zeros((2, N_JOINTS), np.int64)
    grouping[1, [RW0, LW0] + ([] if case == "not_grouped" else [BASE1] if case == "base_only" else [RW1])] = 1
    if case == "base_only":
        for x in tracks:
            x[:, BASE1] = x[:, RW1]  # the base makes the approach; only wrists carry keyframes
    keys = fit_contact_keys(grouping, spans, tracks, np.ones(N_JOINTS, bool), radius=0.2)
    assert not keys.of_type(0) and not keys.of_type(1)
    if case in ("far", "touch_at_end"):  # the reference agrees there is nothing to learn
        _, _, _, closest, ends, _, _ = _reference(tracks, spans, 1, RW1, [RW0, LW0])
        assert closest >= 0.2 or ends < 0.2


def test_contact_radius_is_validated() -> None:
    from socialaff_sim.model.config import AffordanceConfig

    with pytest.raises(ConfigError, match="contact_radius"):
        AffordanceConfig(contact_radius=0.0)
    with pytest.raises(ConfigError, match="contact_width"):
        SynthesisConfig(contact_width=0.0)
    with pytest.raises(ConfigError, match="trigger_scale"):
        SynthesisConfig(trigger_scale=-1.0)
    with pytest.raises(ConfigError, match="'none', 'timed', 'triggered'|none.*timed.*triggered"):
        SynthesisConfig(contact="always")
    with pytest.raises(ConfigError, match="lookahead"):
        SynthesisConfig(contact="timed")


class _Spy(OnlineSynthesizer):
    """Records agent 1's wrists before and after each pull."""

    def _pull_contacts(self, t: int) -> None:
        before = self._track[t].copy()
        super()._pull_contacts(t)
        self.log.append((t, self._sub, self._span, before, self._track[t].copy()))


def test_synthesizer_pulls_wrists_to_the_keyframe(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    seed = 3
    print(f"seed = {seed}")
    model = copy.deepcopy(shake8_model)
    S = model.n_subevents_
    keys = ContactKeys.empty(S)
    offset = np.array([0.1, -0.05, 0.02])
    for s in range(S):  # a keyframe for agent 1's right wrist at mid-interval in every type
        keys.phase[s, RW1 - 5], keys.mate[s, RW1 - 5], keys.offset[s, RW1 - 5] = 0.5, RW0, offset
    model.contact_keys_ = keys
    inter = shake8[7]
    width = 1.5
    cfg = SynthesisConfig.offline(contact_width=width)
    assert cfg.contact == "timed"
    syn = _Spy(model, None, cfg)
    syn.log = []
    syn.reset(inter, rng=np.random.default_rng(seed))
    out = [syn.step() for _ in range(inter.n_frames)]
    pulled = 0
    for t, s, (start, last), before, after in syn.log:
        goal = syn._track[t, RW0] + offset  # agent 0 is read at the frame itself with lookahead
        w = np.exp(-0.5 * ((t - (start + 0.5 * (last - start))) / width) ** 2)
        w = w if abs(t - (start + 0.5 * (last - start))) <= 3 * width else 0.0
        np.testing.assert_allclose(after[RW1], before[RW1] + w * (goal - before[RW1]), rtol=0, atol=1e-12)
        others = np.arange(N_JOINTS) != RW1
        np.testing.assert_array_equal(after[others], before[others])
        if w > 0.99:
            pulled += 1
            assert np.linalg.norm(after[RW1] - goal) <= 0.01 * np.linalg.norm(before[RW1] - goal) + 1e-9
    assert pulled >= 1  # at least one frame lands on a keyframe
    # The emitted joints are the pulled track (mapped back to the recorded labels and the world frame).
    fr = instance_frame(inter)
    emitted = fr.to_canonical(np.stack([o.key_joints for o in out]))
    track = syn._track[:, 5:10]
    if syn._hands[1]:
        track = track[:, [0, 2, 1, 4, 3]]
    np.testing.assert_allclose(emitted[10:], track[10:], rtol=0, atol=1e-9)
    # Without the pull the keyframes change nothing.
    plain = OnlineSynthesizer(shake8_model, None, SynthesisConfig.offline(contact="none"))
    plain.reset(inter, rng=np.random.default_rng(seed))
    ref = np.stack([plain.step().key_joints for _ in range(inter.n_frames)])
    off = OnlineSynthesizer(model, None, SynthesisConfig.offline(contact="none"))
    off.reset(inter, rng=np.random.default_rng(seed))
    np.testing.assert_array_equal(np.stack([off.step().key_joints for _ in range(inter.n_frames)]), ref)


def test_causal_pull_is_triggered_by_the_touched_joints_pose(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    seed = 5
    print(f"seed = {seed}")
    model = copy.deepcopy(shake8_model)
    inter = shake8[6]
    x = model.canonical_track(inter)
    # The contact pose: agent 0's right wrist relative to its base on frame 20 of this very instance.
    pose = x[20, RW0] - x[20, 0]
    keys = ContactKeys.empty(model.n_subevents_)
    keys.phase[0, RW1 - 5], keys.mate[0, RW1 - 5], keys.offset[0, RW1 - 5] = 0.5, RW0, [0.08, 0.0, 0.0]
    keys.pose[0, RW1 - 5], keys.spread[0, RW1 - 5] = pose, 0.1
    model.contact_keys_ = keys
    cfg = SynthesisConfig.reactive(trigger_scale=1.5)
    assert cfg.contact == "triggered" and not cfg.lookahead
    syn = _Spy(model, None, cfg)
    syn.log = []
    syn.reset(inter, rng=np.random.default_rng(seed))
    for _ in range(inter.n_frames):
        syn.step()
    weights = []
    for t, _, _, before, after in syn.log:
        x0 = syn._track[t - 1]  # causal: agent 0 read at the latest observed frame
        d = np.linalg.norm(x0[RW0] - x0[0] - pose) / (1.5 * 0.1)
        w = np.exp(-0.5 * d * d) if d <= 3.0 else 0.0
        goal = x0[RW0] + [0.08, 0.0, 0.0]
        np.testing.assert_allclose(after[RW1], before[RW1] + w * (goal - before[RW1]), rtol=0, atol=1e-12)
        weights.append(w)
    # The weight peaks on the frame after agent 0's wrist holds the contact pose, whatever the sub-event.
    assert max(weights) > 0.99 and syn.log[int(np.argmax(weights))][0] == 21
