"""Tests of the embedded synthetic dataset (socialaff_sim.data.synthetic)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data import Interaction, actor_disjoint_folds, get_layout, load_npz_dataset, save_dataset
from socialaff_sim.data.synthetic import (
    BALL_RADIUS,
    CUP_RADIUS,
    GRAVITY,
    INTERACTIONS,
    SUBEVENTS,
    SyntheticConfig,
    actor_pairs,
    generate_actors,
    generate_dataset,
    generate_instance,
)
from socialaff_sim.data.synthetic.body import JOINT
from socialaff_sim.data.synthetic.ik import two_link_ik
from socialaff_sim.data.synthetic.motion import cruise, keyframes, minjerk, plan_timeline
from socialaff_sim.data.synthetic.noise import ar1_noise
from socialaff_sim.errors import ConfigError

SEED = 20240611
"""Seed of the module-wide datasets (printed by the fixtures)."""
LAYOUT = get_layout("kinect_v2")
CLEAN = SyntheticConfig(noise=False)


@pytest.fixture(scope="module")
def clean():
    print(f"dataset seed = {SEED} (clean)")
    return generate_dataset(SEED, CLEAN)


@pytest.fixture(scope="module")
def noisy():
    print(f"dataset seed = {SEED} (noisy)")
    return generate_dataset(SEED)


@pytest.fixture(scope="module")
def actors():
    return {a.actor_id: a for a in generate_actors(SEED, CLEAN)}


def _frames(inter: Interaction, name: str, *, closed: bool = False) -> np.ndarray:
    """Frame indices of one sub-event (plus the next frame if ``closed``)."""
    k = inter.subevent_names.index(name)
    idx = np.flatnonzero(inter.subevents == k)
    return np.append(idx, idx[-1] + 1) if closed and idx[-1] + 1 < inter.n_frames else idx


def _joint(inter: Interaction, agent: int, name: str) -> np.ndarray:
    return inter.joints[:, agent, JOINT[name]]


def _same_arrays(a: Interaction, b: Interaction) -> bool:
    fields = ("joints", "valid", "object", "subevents")
    return a.same_as(b) and all(
        (getattr(a, f) is None and getattr(b, f) is None)
        or np.array_equal(getattr(a, f), getattr(b, f), equal_nan=getattr(a, f).dtype.kind == "f")
        for f in fields
    )


# -- determinism and seeding --------------------------------------------------------------------


def test_same_seed_is_bit_identical(noisy):
    again = generate_dataset(SEED)
    assert len(again) == len(noisy)
    assert all(_same_arrays(a, b) for a, b in zip(noisy, again, strict=True))


def test_different_seeds_differ(noisy):
    other = generate_dataset(SEED + 1)
    assert [i.instance_id for i in other] == [i.instance_id for i in noisy]
    differ = [not a.same_as(b, atol=1e-6) for a, b in zip(noisy, other, strict=True)]
    assert all(differ)


def test_subset_and_more_instances_leave_the_rest_unchanged(noisy):
    sub = generate_dataset(SEED, SyntheticConfig(interactions=("pull_up",)))
    ref = noisy.of_label("pull_up")
    assert all(_same_arrays(a, b) for a, b in zip(sub, ref, strict=True))
    more = generate_dataset(SEED, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=30))
    ref = noisy.of_label("hand_over")
    assert len(more) == 30
    assert all(_same_arrays(a, b) for a, b in zip(more.interactions[:24], ref, strict=True))


def test_clean_and_noisy_share_the_motion(clean, noisy):
    for a, b in zip(clean, noisy, strict=True):
        assert a.fps == b.fps and a.actors == b.actors
        np.testing.assert_array_equal(a.subevents, b.subevents)
        ok = b.valid
        assert np.abs(a.joints[ok] - b.joints[ok]).max() < 0.5


def test_generate_instance_is_driven_by_the_rng_only(actors, seed):
    pair = (actors["a01"], actors["a02"])
    one = generate_instance("hand_over", pair, np.random.default_rng(seed), CLEAN)
    two = generate_instance("hand_over", pair, np.random.default_rng(seed), CLEAN)
    three = generate_instance("hand_over", pair, np.random.default_rng(seed + 1), CLEAN)
    assert _same_arrays(one, two)
    assert not one.same_as(three, atol=1e-6)
    assert one.actors == ("a01", "a02") and one.object is not None


# -- dataset structure ----------------------------------------------------------------------------


def test_counts_ids_and_names(noisy):
    assert noisy.name == "synthetic"
    assert set(noisy.labels) == set(INTERACTIONS)
    for label in INTERACTIONS:
        assert len(noisy.of_label(label)) == 24
    ids = [i.instance_id for i in noisy]
    assert len(set(ids)) == len(ids) == 120
    assert all(re.fullmatch(rf"{i.label}_\d{{3}}", i.instance_id) for i in noisy)
    assert all(i.joint_names == LAYOUT.joint_names for i in noisy)
    assert all((i.object is not None) == (i.label in ("throw_catch", "hand_over")) for i in noisy)


def test_fps_and_durations_in_range(noisy):
    fps = np.array([i.fps for i in noisy])
    dur = np.array([i.duration for i in noisy])
    assert fps.min() >= 10.0 and fps.max() <= 15.0
    assert dur.min() >= 2.0 and dur.max() <= 7.0
    assert np.unique(fps).size > 60  # drawn per instance


def test_actor_pairs_allow_actor_disjoint_folds(noisy, rng):
    ids = {f"a{k:02d}" for k in range(1, 9)}
    for label in INTERACTIONS:
        group = noisy.of_label(label).interactions
        assert all(a != b and {a, b} <= ids for a, b in (i.actors for i in group))
        pairs = {tuple(sorted(i.actors)) for i in group}
        assert len(pairs) >= 8
        assert {i.actors[0] for i in group} == ids  # every actor also plays the observed human
        for train, test in actor_disjoint_folds(group, 4, rng=rng):
            train_pairs = {tuple(sorted(group[k].actors)) for k in train}
            assert not train_pairs & {tuple(sorted(group[k].actors)) for k in test}


@pytest.mark.parametrize(("n_actors", "n_pairs"), [(8, 8), (8, 28), (5, 10), (2, 1)])
def test_actor_pairs_are_distinct_and_balanced(n_actors, n_pairs, rng):
    pairs = actor_pairs(n_actors, n_pairs, rng)
    unordered = {frozenset(p) for p in pairs}
    assert len(pairs) == len(unordered) == n_pairs
    assert all(len(p) == 2 for p in unordered)
    counts = np.bincount(np.ravel(pairs), minlength=n_actors)
    assert counts.max() - counts.min() <= (1 if n_actors % 2 == 0 else 2)


def test_subevents_cover_every_frame_in_scripted_order(noisy):
    for inter in noisy:
        names = SUBEVENTS[inter.label]
        assert inter.subevent_names == names
        sub = inter.subevents
        assert sub.min() == 0 and sub.max() == len(names) - 1
        assert np.all(np.diff(sub) >= 0)
        np.testing.assert_array_equal(np.unique(sub), np.arange(len(names)))
        assert np.bincount(sub).min() >= 2


def test_npz_round_trip(noisy, tmp_path):
    paths = save_dataset(noisy, tmp_path)
    assert len(paths) == len(noisy)
    loaded = load_npz_dataset(tmp_path)
    by_id = {i.instance_id: i for i in loaded}
    assert set(by_id) == {i.instance_id for i in noisy}
    for inter in noisy:
        back = by_id[inter.instance_id]
        assert _same_arrays(inter, back)
        assert back.source == inter.source


# -- bodies ---------------------------------------------------------------------------------------


def test_bone_lengths_are_constant_per_actor(clean):
    bones = LAYOUT.bones
    per_actor: dict[str, np.ndarray] = {}
    for inter in clean:
        lengths = np.linalg.norm(inter.joints[:, :, bones[:, 1]] - inter.joints[:, :, bones[:, 0]], axis=-1)
        first = np.broadcast_to(lengths[:1], lengths.shape)
        np.testing.assert_allclose(lengths, first, rtol=0, atol=1e-9)  # constant in time
        for agent, actor in enumerate(inter.actors):
            ref = per_actor.setdefault(actor, lengths[0, agent])
            np.testing.assert_allclose(lengths[0, agent], ref, rtol=0, atol=1e-9)  # same body in every instance
    assert len(per_actor) == 8
    assert len({round(float(v.sum()), 6) for v in per_actor.values()}) == 8


def test_actor_heights(clean, actors):
    heights = np.array([a.height for a in actors.values()])
    assert heights.min() >= 1.5 and heights.max() <= 1.95
    assert np.unique(np.round(heights, 3)).size == 8
    assert heights.max() - heights.min() > 0.3
    for inter in clean:
        if inter.label == "pull_up":
            continue  # agent 0 starts seated
        for agent, actor_id in enumerate(inter.actors):
            head = _joint(inter, agent, "head")[0, 2]  # standing still in the first frame
            np.testing.assert_allclose(head, actors[actor_id].standing_head_height, atol=0.01)
            np.testing.assert_allclose(head / actors[actor_id].height, 0.9261, atol=0.002)


def test_floor_and_upright_bodies(clean):
    for inter in clean:
        z = inter.joints[..., 2]
        assert z.min() >= 0.0
        feet = inter.joints[:, :, [JOINT["left_foot"], JOINT["right_foot"]], 2]
        assert feet.min(axis=(0, 2)).max() < 0.05  # both agents stand on the floor
        assert np.all(_joint(inter, 0, "head")[:, 2] > _joint(inter, 0, "spine_base")[:, 2] + 0.3)


def test_room_placement_varies(clean):
    start = np.array([i.joints[0, 1, 0, :2] - i.joints[0, 0, 0, :2] for i in clean])
    angles = np.arctan2(start[:, 1], start[:, 0])
    resultant = np.abs(np.mean(np.exp(1j * angles)))
    assert resultant < 0.3  # pair headings spread around the circle
    centres = np.array([i.joints[0, :, 0, :2].mean(axis=0) for i in clean])
    assert centres.std(axis=0).min() > 0.4


# -- contacts at the contact sub-events ------------------------------------------------------------


def test_shake_hands_right_wrists_meet(clean):
    for inter in clean.of_label("shake_hands"):
        f = _frames(inter, "shake", closed=True)
        gap = np.linalg.norm(_joint(inter, 0, "right_wrist")[f] - _joint(inter, 1, "right_wrist")[f], axis=-1)
        assert gap.max() < 0.10
        before = np.linalg.norm(_joint(inter, 0, "right_wrist")[0] - _joint(inter, 1, "right_wrist")[0])
        assert before > 0.5
        bases = np.linalg.norm(inter.joints[:, 0, 0] - inter.joints[:, 1, 0], axis=-1)
        assert bases[f].min() > 0.6  # bodies stay apart
        osc = _joint(inter, 0, "right_wrist")[_frames(inter, "shake"), 2]
        assert np.ptp(osc) > 0.015  # the hands pump


def test_high_five_hands_meet_above_shoulders(clean):
    sides = set()
    for inter in clean.of_label("high_five"):
        f = _frames(inter, "strike")
        gaps = {
            s: np.linalg.norm(_joint(inter, 0, f"{s}_wrist")[f] - _joint(inter, 1, f"{s}_wrist")[f], axis=-1)
            for s in ("left", "right")
        }
        side = min(gaps, key=lambda s: gaps[s].min())
        sides.add(side)
        assert gaps[side].min() < 0.15
        for agent in (0, 1):
            wrist = _joint(inter, agent, f"{side}_wrist")[f, 2]
            shoulder = _joint(inter, agent, f"{side}_shoulder")[f, 2]
            assert np.all(wrist > shoulder)
    assert sides == {"left", "right"}


def test_hand_over_cup_between_both_hands(clean):
    for inter in clean.of_label("hand_over"):
        f = _frames(inter, "transfer", closed=True)
        cup = inter.object[f]
        d0 = np.linalg.norm(cup - _joint(inter, 0, "right_hand")[f], axis=-1)
        d1 = np.minimum(
            np.linalg.norm(cup - _joint(inter, 1, "left_hand")[f], axis=-1),
            np.linalg.norm(cup - _joint(inter, 1, "right_hand")[f], axis=-1),
        )
        np.testing.assert_allclose(d0, CUP_RADIUS, atol=0.01)
        np.testing.assert_allclose(d1, CUP_RADIUS, atol=0.01)
        first = _frames(inter, "approach")
        d_carry = np.linalg.norm(inter.object[first] - _joint(inter, 0, "right_hand")[first], axis=-1)
        np.testing.assert_allclose(d_carry, CUP_RADIUS, atol=1e-6)  # carried by agent 0 until then
        steps = np.linalg.norm(np.diff(inter.object, axis=0), axis=-1) * inter.fps
        assert steps.max() < 4.0  # the cup moves continuously (m/s)


def test_throw_catch_ball_is_ballistic_and_caught(clean, noisy):
    for inter, rough in zip(clean.of_label("throw_catch"), noisy.of_label("throw_catch"), strict=True):
        f = _frames(inter, "flight", closed=True)  # release frame .. catch frame
        assert f.size >= 6
        t = f / inter.fps
        ball = inter.object
        quad = np.polyfit(t, ball[f, 2], 2)
        np.testing.assert_allclose(2 * quad[0], -GRAVITY, atol=1e-6)
        for axis in (0, 1):  # no horizontal acceleration
            lin = np.polyfit(t, ball[f, axis], 1)
            np.testing.assert_allclose(np.polyval(lin, t), ball[f, axis], atol=1e-9)
        assert ball[f, 2].max() > ball[f[[0, -1]], 2].max() + 0.1  # a real arc
        noisy_quad = np.polyfit(t, rough.object[f, 2], 2)
        np.testing.assert_allclose(2 * noisy_quad[0], -GRAVITY, atol=1.5)
        travel = np.linalg.norm(ball[f[-1], :2] - ball[f[0], :2])
        assert 1.2 < travel < 3.5
        caught = np.concatenate([_frames(inter, "catch"), _frames(inter, "hold")])
        for hand in ("left_hand", "right_hand"):
            d = np.linalg.norm(ball[caught] - _joint(inter, 1, hand)[caught], axis=-1)
            np.testing.assert_allclose(d, BALL_RADIUS, atol=0.01)
        held = np.concatenate([_frames(inter, "wind_up"), _frames(inter, "throw")])
        d0 = np.minimum(
            np.linalg.norm(ball[held] - _joint(inter, 0, "left_hand")[held], axis=-1),
            np.linalg.norm(ball[held] - _joint(inter, 0, "right_hand")[held], axis=-1),
        )
        np.testing.assert_allclose(d0, BALL_RADIUS, atol=1e-6)
        distance = np.linalg.norm(inter.joints[0, 1, 0, :2] - inter.joints[0, 0, 0, :2])
        assert 2.5 <= distance <= 3.5


def test_pull_up_agent_rises_and_grip_holds(clean, noisy):
    for inter, rough in zip(clean.of_label("pull_up"), noisy.of_label("pull_up"), strict=True):
        base = inter.joints[:, 0, 0, 2]
        assert base[-1] - base[0] > 0.3
        assert np.all(np.diff(base[_frames(inter, "approach")]) == 0)  # seated still
        noisy_base = rough.key_joints()[:, 0, 0, 2]
        assert noisy_base[-3:].mean() - noisy_base[:3].mean() > 0.25
        knee = _joint(inter, 0, "left_knee")[0, 2]
        hip = _joint(inter, 0, "left_hip")[0, 2]
        assert abs(knee - hip) < 0.12  # thighs about level when seated
        f = _frames(inter, "pull", closed=True)
        gaps = [
            np.linalg.norm(_joint(inter, 0, f"{s}_wrist")[f] - _joint(inter, 1, f"{s}_wrist")[f], axis=-1)
            for s in ("left", "right")
        ]
        assert min(g.max() for g in gaps) < 0.12


def test_approach_moves_bases_then_they_settle(clean):
    for label in ("shake_hands", "high_five", "hand_over"):
        for inter in clean.of_label(label):
            f = _frames(inter, "approach", closed=True)
            moved = np.linalg.norm(inter.joints[f[-1], :, 0, :2] - inter.joints[f[0], :, 0, :2], axis=-1)
            assert moved.sum() > 0.9
            later = np.arange(f[-1], inter.n_frames)
            drift = np.linalg.norm(inter.joints[later, :, 0, :2] - inter.joints[f[-1], :, 0, :2], axis=-1)
            assert drift.max() < 1e-9
            ankles = inter.joints[f][:, :, [JOINT["left_ankle"], JOINT["right_ankle"]], 2]
            assert ankles.max() - ankles.min() > 0.04  # feet lift while walking


# -- corruption -------------------------------------------------------------------------------------


def test_dropped_joints_are_invalid_and_nan(clean, noisy):
    for inter in noisy:
        nan = np.isnan(inter.joints).any(axis=-1)
        np.testing.assert_array_equal(nan, ~inter.valid)
        assert np.isnan(inter.joints[~inter.valid]).all()
        assert np.isfinite(inter.key_joints()).all()  # gaps are short enough to fill
        if inter.object is not None:
            assert np.isfinite(inter.object).all()
    assert all(i.valid.all() and np.isfinite(i.joints).all() for i in clean)
    assert sum(int((~i.valid).sum()) for i in noisy) > 100


def test_noise_statistics_match_the_config():
    config = SyntheticConfig(
        interactions=("shake_hands", "throw_catch"),
        instances_per_interaction=12,
        jitter_sd=0.02,
        occluded_jitter_sd=0.02,
        jitter_correlation=0.6,
        dropout=0.03,
        occluded_dropout=0.03,
        object_jitter_sd=0.01,
    )
    print(f"dataset seed = {SEED}")
    noisy = generate_dataset(SEED, config)
    clean = generate_dataset(SEED, dataclasses.replace(config, noise=False))
    err, lagged, dropped, total, obj_err = [], [], 0, 0, []
    for a, b in zip(clean, noisy, strict=True):
        e = b.joints - a.joints
        err.append(e[b.valid])
        both = b.valid[1:] & b.valid[:-1]
        lagged.append(np.stack([e[1:][both], e[:-1][both]], axis=-1))
        dropped += int((~b.valid).sum())
        total += b.valid.size
        if a.object is not None:
            obj_err.append(b.object - a.object)
    err = np.concatenate(err)
    np.testing.assert_allclose(err.std(), 0.02, rtol=0.03)
    np.testing.assert_allclose(err.mean(), 0.0, atol=1e-3)
    pairs = np.concatenate(lagged).reshape(-1, 2)
    np.testing.assert_allclose(np.corrcoef(pairs.T)[0, 1], 0.6, atol=0.03)
    assert stats.binomtest(dropped, total, 0.03).pvalue > 1e-4
    obj_err = np.concatenate(obj_err).ravel()
    np.testing.assert_allclose(obj_err.std(), 0.01, rtol=0.05)


def test_occluded_hands_are_noisier():
    config = SyntheticConfig(
        interactions=("shake_hands",), jitter_sd=0.01, occluded_jitter_sd=0.08, dropout=0.0, occluded_dropout=0.0
    )
    print(f"dataset seed = {SEED}")
    noisy = generate_dataset(SEED, config)
    clean = generate_dataset(SEED, dataclasses.replace(config, noise=False))
    inside, outside = [], []
    for a, b in zip(clean, noisy, strict=True):
        f = _frames(a, "shake")
        e = b.joints[:, :, JOINT["right_wrist"]] - a.joints[:, :, JOINT["right_wrist"]]
        inside.append(e[f].ravel())
        outside.append(np.delete(e, f, axis=0).ravel())
        assert b.valid.all()
    np.testing.assert_allclose(np.concatenate(inside).std(), 0.08, rtol=0.1)
    np.testing.assert_allclose(np.concatenate(outside).std(), 0.01, rtol=0.1)


def test_ar1_noise_against_its_closed_form(rng):
    x = ar1_noise(rng, (4000, 50), 0.7)
    np.testing.assert_allclose(x.std(axis=1).mean(), 1.0, atol=0.02)  # stationary from frame 0
    np.testing.assert_allclose(x[0].std(), 1.0, atol=0.25)
    for lag in (1, 2, 3):
        r = np.mean(x[lag:] * x[:-lag]) / np.mean(x * x)
        np.testing.assert_allclose(r, 0.7**lag, atol=0.02)


# -- kinematic building blocks ------------------------------------------------------------------------


def test_two_link_ik_against_geometry(rng):
    root = rng.normal(size=(500, 3))
    upper, lower = 0.3, 0.25
    direction = rng.normal(size=(500, 3))
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    dist = rng.uniform(0.1, 0.7, size=(500, 1))
    target = root + dist * direction
    pole = rng.normal(size=(500, 3))
    middle, end, bend = two_link_ik(root, target, upper, lower, pole)
    np.testing.assert_allclose(np.linalg.norm(middle - root, axis=-1), upper, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(end - middle, axis=-1), lower, atol=1e-12)
    reachable = ((dist > abs(upper - lower) + 1e-3) & (dist < 0.999 * (upper + lower)))[:, 0]
    np.testing.assert_allclose(end[reachable], target[reachable], atol=1e-9)
    far = (dist >= 0.999 * (upper + lower))[:, 0]
    np.testing.assert_allclose(end[far], root[far] + 0.999 * (upper + lower) * direction[far], atol=1e-9)
    # the middle joint bends toward the pole, in the plane of root, target and pole
    side = np.sum((middle - root) * bend, axis=-1)
    assert np.all(side[reachable] >= -1e-12)
    normal = np.cross(direction, pole)
    np.testing.assert_allclose(np.sum((middle - root) * normal, axis=-1)[reachable], 0.0, atol=1e-9)


def test_minjerk_keyframes_and_cruise_by_finite_differences():
    u = np.linspace(0.0, 1.0, 20001)
    h = u[1] - u[0]
    s = minjerk(u)
    v = np.gradient(s, h)
    np.testing.assert_allclose([s[0], s[-1], v[0], v[-1]], [0.0, 1.0, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(v.max(), 1.875, atol=1e-6)  # the closed-form peak speed 15/8
    c = cruise(u, 0.25)
    vc = np.gradient(c, h)
    np.testing.assert_allclose([c[0], c[-1]], [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(vc[(u > 0.3) & (u < 0.7)], 1 / 0.75, atol=1e-6)
    assert np.all(np.diff(c) >= 0.0)
    t = np.linspace(0.0, 3.0, 301)
    k = keyframes(t, [0.5, 1.5, 2.5], [[0.0, 1.0], [2.0, -1.0], [2.0, 3.0]])
    np.testing.assert_allclose(k[[0, 50, 150, 250, 300]], [[0, 1], [0, 1], [2, -1], [2, 3], [2, 3]], atol=1e-12)


@pytest.mark.parametrize("fps", [10.0, 12.5, 15.0])
def test_plan_timeline_respects_ranges(fps, rng):
    config = SyntheticConfig(duration_range=(2.0, 2.5))
    for _ in range(20):
        tl = plan_timeline(("a", "b", "c", "d"), [(0.1, 3.0)] * 4, fps, rng, config)
        assert 2.0 <= tl.n_frames / fps <= 2.5
        assert np.diff(tl.bounds).min() >= 2
        assert tl.labels().shape == (tl.n_frames,)


# -- configuration errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("interactions", ("dance",)),
        ("instances_per_interaction", 0),
        ("n_actors", 1),
        ("fps_range", (15.0, 10.0)),
        ("height_range", (1.5,)),
        ("dropout", 0.9),
        ("jitter_correlation", 1.0),
        ("jitter_sd", -0.1),
    ],
)
def test_bad_config_raises_naming_the_field(field, value):
    with pytest.raises(ConfigError, match=field):
        SyntheticConfig(**{field: value})


def test_bad_calls_raise(actors, rng):
    with pytest.raises(ConfigError, match="shake_hands"):
        generate_instance("waltz", (actors["a01"], actors["a02"]), rng)
    with pytest.raises(ConfigError, match="two different actors"):
        generate_instance("high_five", (actors["a03"], actors["a03"]), rng)
    with pytest.raises(ConfigError, match="seed"):
        generate_dataset(-1)
