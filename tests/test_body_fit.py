"""Full-body fit: K-means pose clusters and analytic two-bone IK reach key-joint targets."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from socialaff_sim.data import Interaction, get_layout
from socialaff_sim.errors import NotFittedError
from socialaff_sim.inference.body_fit import BodyFitConfig, BodyFitter, instance_frame, kmeans, two_bone_ik

KINECT = get_layout("kinect_v2")

# A standing Kinect v2 skeleton in its body frame (x forward, y left, z up), metres.
_REST = {
    "spine_base": (0, 0, 0.95), "spine_mid": (0, 0, 1.2), "spine_shoulder": (0, 0, 1.42),
    "neck": (0, 0, 1.5), "head": (0, 0, 1.65),
    "left_shoulder": (0, 0.18, 1.42), "left_elbow": (0.02, 0.2, 1.15), "left_wrist": (0.04, 0.2, 0.9),
    "left_hand": (0.05, 0.2, 0.82), "left_hand_tip": (0.06, 0.2, 0.75), "left_thumb": (0.08, 0.18, 0.84),
    "left_hip": (0, 0.1, 0.92), "left_knee": (0.03, 0.1, 0.5), "left_ankle": (0, 0.1, 0.08),
    "left_foot": (0.1, 0.1, 0.03),
}
for _name, (_x, _y, _z) in list(_REST.items()):
    if _name.startswith("left_"):
        _REST["right_" + _name[5:]] = (_x, -_y, _z)
REST = np.array([_REST[n] for n in KINECT.joint_names], dtype=np.float64)


def _rot_y(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros(np.shape(angle) + (3, 3))
    r[..., 0, 0], r[..., 0, 2], r[..., 1, 1], r[..., 2, 0], r[..., 2, 2] = c, s, 1.0, -s, c
    return r


def standing_skeleton(raise_right: np.ndarray, raise_left: np.ndarray | float = 0.0, bend: float = 0.3) -> np.ndarray:
    """(T, 25, 3) skeletons in the body frame; arms raised forward by the given angles (radians)."""
    raise_right = np.atleast_1d(np.asarray(raise_right, dtype=np.float64))
    raise_left = np.broadcast_to(np.asarray(raise_left, dtype=np.float64), raise_right.shape)
    out = np.repeat(REST[None], len(raise_right), axis=0)
    for side, angle in (("right", raise_right), ("left", raise_left)):
        sh = KINECT.index(f"{side}_shoulder")
        el = KINECT.index(f"{side}_elbow")
        arm = [KINECT.index(f"{side}_{n}") for n in ("elbow", "wrist", "hand", "hand_tip", "thumb")]
        fore = arm[1:]
        # Shoulder flexion (negative rotation about y lifts the arm forward), then an elbow bend.
        r = _rot_y(-angle)
        out[:, arm] = REST[sh] + np.einsum("tij,nj->tni", r, REST[arm] - REST[sh])
        r2 = _rot_y(-bend * np.ones_like(angle))
        out[:, fore] = out[:, el, None] + np.einsum("tij,tnj->tni", r @ r2 @ np.swapaxes(r, -1, -2), out[:, fore] - out[:, el, None])
    return out


def place(body: np.ndarray, origin: np.ndarray, yaw: float) -> np.ndarray:
    """Body-frame skeletons → world: rotate by ``yaw`` about z and translate to ``origin`` (x, y)."""
    c, s = np.cos(yaw), np.sin(yaw)
    r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return body @ r.T + np.array([origin[0], origin[1], 0.0])


@pytest.fixture
def fitter(rng: np.random.Generator) -> BodyFitter:
    angles = rng.uniform(0.0, 1.6, size=(400, 2))
    skel = standing_skeleton(angles[:, 0], angles[:, 1])
    return BodyFitter(BodyFitConfig(n_clusters=12)).fit(skel, KINECT, rng=rng)


def _bone_lengths(poses: np.ndarray) -> np.ndarray:
    b = KINECT.bones
    return np.linalg.norm(poses[..., b[:, 1], :] - poses[..., b[:, 0], :], axis=-1)


def test_reachable_targets_are_reached_and_bone_lengths_kept(fitter: BodyFitter, rng: np.random.Generator) -> None:
    cl = rng.integers(len(fitter.poses_), size=30)
    base = rng.normal(size=(30, 3)) * [1.0, 1.0, 0.05] + [0.0, 0.0, 0.95]
    targets = fitter.keys_[cl] + base[:, None]
    # Move each wrist/ankle a few centimetres toward its shoulder/hip: still within reach.
    roots = [KINECT.index(n) for n in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")]
    toward = fitter.poses_[cl][:, roots] + base[:, None] - targets[:, 1:]
    targets[:, 1:] += 0.15 * toward + rng.normal(scale=0.01, size=toward.shape)
    poses = fitter.fit_poses(targets)
    key_idx = [i for i in KINECT.key_indices if i is not None]
    np.testing.assert_allclose(poses[:, key_idx], targets, atol=1e-6)
    expected = fitter.bone_lengths_[KINECT.bones[:, 1]]
    np.testing.assert_allclose(_bone_lengths(poses), np.broadcast_to(expected, (30, len(expected))), atol=1e-9)


def test_unreachable_target_gives_a_stretched_limb_pointing_at_it(fitter: BodyFitter) -> None:
    targets = fitter.keys_[:1].copy()
    targets[0, 2] = targets[0, 0] + np.array([3.0, -0.5, 1.0])  # right wrist 3 m away
    pose = fitter.fit_pose(targets[0])
    sh, el, wr = (KINECT.index(f"right_{n}") for n in ("shoulder", "elbow", "wrist"))
    reach = fitter.bone_lengths_[el] + fitter.bone_lengths_[wr]
    arm = pose[wr] - pose[sh]
    goal = targets[0, 2] - pose[sh]
    np.testing.assert_allclose(np.linalg.norm(arm), reach, atol=1e-9)
    np.testing.assert_allclose(arm / np.linalg.norm(arm), goal / np.linalg.norm(goal), atol=1e-9)
    np.testing.assert_allclose(np.cross(pose[el] - pose[sh], goal), 0.0, atol=1e-9)  # elbow on the line too


def test_target_in_the_limb_plane_keeps_the_bend_plane(rng: np.random.Generator) -> None:
    root = np.zeros((20, 3))
    mid = np.tile([0.3, 0.0, 0.0], (20, 1)) + rng.normal(scale=0.01, size=(20, 3))
    end = mid + np.tile([0.0, 0.25, 0.0], (20, 1))
    normal = np.cross(mid - root, end - root)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    # Targets in the limb's plane at a reachable distance (|a - b| < r < a + b).
    e1 = (mid - root) / np.linalg.norm(mid - root, axis=1, keepdims=True)
    e2 = np.cross(normal, e1)
    phi, r = rng.uniform(-np.pi, np.pi, size=20), rng.uniform(0.1, 0.5, size=20)
    target = root + r[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    new_mid, new_end = two_bone_ik(root, mid, end, target)
    np.testing.assert_allclose(np.einsum("td,td->t", new_mid - root, normal), 0.0, atol=1e-12)
    np.testing.assert_allclose(new_end, target, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(new_mid - root, axis=1), np.linalg.norm(mid - root, axis=1), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(new_end - new_mid, axis=1), np.linalg.norm(end - mid, axis=1), atol=1e-12)


def test_vectorized_fit_equals_frame_by_frame_and_world_frame(fitter: BodyFitter, rng: np.random.Generator) -> None:
    targets = fitter.keys_[rng.integers(len(fitter.keys_), size=8)] + rng.normal(scale=0.05, size=(8, 5, 3))
    batch = fitter.fit_poses(targets)
    one = np.stack([fitter.fit_pose(t) for t in targets])
    np.testing.assert_allclose(batch, one, atol=1e-12)
    body = standing_skeleton(np.zeros(3))
    joints = np.stack([place(body, (0.0, 0.0), 0.4), place(body, (1.0, 0.7), 0.4 + np.pi)], axis=1)
    inter = Interaction("shake_hands", 10.0, joints, KINECT.joint_names, ("a", "b"))
    frame = instance_frame(inter)
    world_targets = frame.to_world(targets)
    np.testing.assert_allclose(fitter.fit_poses(world_targets, frame), frame.to_world(batch), atol=1e-9)


def test_instance_frame_is_the_canonical_frame_of_the_first_frame() -> None:
    body = standing_skeleton(np.zeros(4))
    joints = np.stack([place(body, (2.0, 1.0), 0.3), place(body, (2.0, 2.5), -1.0)], axis=1)
    frame = instance_frame(Interaction("shake_hands", 10.0, joints, KINECT.joint_names, ("a", "b")))
    np.testing.assert_allclose(frame.origin, [2.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(frame.rotation[:, 0], [0.0, 1.0, 0.0], atol=1e-12)  # toward agent 1
    np.testing.assert_allclose(frame.rotation[:, 2], [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(frame.rotation.T @ frame.rotation, np.eye(3), atol=1e-12)
    local = frame.to_canonical(joints[0, 1, 0])
    np.testing.assert_allclose(local, [1.5, 0.0, 0.95], atol=1e-12)
    np.testing.assert_allclose(frame.to_world(frame.to_canonical(joints)), joints, atol=1e-12)


def test_kmeans_recovers_separated_blobs(rng: np.random.Generator) -> None:
    centres = rng.normal(scale=10.0, size=(5, 3))
    truth = rng.integers(5, size=300)
    pts = centres[truth] + rng.normal(scale=0.1, size=(300, 3))
    _, labels = kmeans(pts, 5, rng=rng)
    confusion = np.zeros((5, 5), dtype=np.int64)
    np.add.at(confusion, (truth, labels), 1)
    rows, cols = linear_sum_assignment(-confusion)
    assert confusion[rows, cols].sum() == 300
    c1, l1 = kmeans(pts, 5)
    c2, l2 = kmeans(pts, 5)
    np.testing.assert_array_equal(l1, l2)
    np.testing.assert_allclose(c1, c2, atol=0.0)


def test_limb_chains_per_layout_and_errors() -> None:
    with pytest.raises(NotFittedError, match="fit"):
        BodyFitter().fit_pose(np.zeros((5, 3)))
    assert len(BodyFitter._limb_chains(get_layout("sbu15"))) == 4
    assert len(BodyFitter._limb_chains(get_layout("nuitrack10"))) == 2
    key5 = get_layout("key5")
    fit = BodyFitter().fit(np.tile(np.arange(15.0).reshape(1, 5, 3), (3, 1, 1)), key5)
    targets = np.arange(15.0).reshape(5, 3) * 0.1
    np.testing.assert_allclose(fit.fit_pose(targets), targets, atol=1e-12)


def test_never_tracked_joints_are_left_out(rng: np.random.Generator) -> None:
    angles = rng.uniform(0.0, 1.6, size=(200, 2))
    skel = standing_skeleton(angles[:, 0], angles[:, 1])
    leg = [KINECT.index(n) for n in ("left_knee", "left_ankle", "left_foot")]
    skel[:, leg] = np.nan  # e.g. a giver whose legs were never tracked
    fit = BodyFitter(BodyFitConfig(n_clusters=6)).fit(skel, KINECT, rng=rng)
    targets = fit.keys_[:3].copy()
    shoulder = fit.poses_[:3, KINECT.index("right_shoulder")]
    targets[:, 2] += 0.2 * (shoulder - targets[:, 2])  # move the right wrist toward the shoulder: reachable
    poses = fit.fit_poses(targets)
    assert np.isnan(poses[:, leg]).all() and np.isfinite(np.delete(poses, leg, axis=1)).all()
    np.testing.assert_allclose(poses[:, KINECT.index("right_wrist")], targets[:, 2], atol=1e-6)
    np.testing.assert_allclose(poses[:, KINECT.index("right_ankle")], targets[:, 4], atol=1e-6)


def test_independent_limbs_solved_as_one_stack_equal_limb_by_limb(fitter: BodyFitter, rng: np.random.Generator) -> None:
    """The limbs of a humanoid move none of each other's roots, elbows/knees or ends, so fit_poses stacks their
    two-bone problems: bitwise the limb-by-limb fit (missing targets, one frame or several). A chain that moves another
    chain's root makes the fitter solve limb by limb."""
    assert fitter._independent and len(fitter._chains) == 4
    limb_by_limb = copy.copy(fitter)
    limb_by_limb._independent = False
    for n in (1, 1, 4):
        targets = fitter.keys_[rng.integers(0, len(fitter.keys_), n)] + rng.normal(0, 0.2, (n, 5, 3))
        targets[:, 1:] += targets[:, :1]
        targets[0, int(rng.integers(1, 5))] = np.nan
        assert np.array_equal(fitter.fit_poses(targets), limb_by_limb.fit_poses(targets), equal_nan=True)
    k, root, mid, end, mid_sub, end_sub = fitter._chains[0]
    chained = copy.copy(fitter)
    chained._limb_chains = lambda layout: [fitter._chains[0], (k, mid, end, end_sub[1], end_sub[2:], end_sub[1:2])]
    skeletons = fitter.poses_ + rng.normal(0, 0.01, fitter.poses_.shape)
    assert not chained.fit(skeletons, fitter.layout_, rng=rng)._independent


def test_frames_with_every_target_fitted_in_place_equal_gathered_rows(fitter: BodyFitter, rng: np.random.Generator) -> None:
    """fit_poses works on slices when every frame has every limb target (a stream's call), else on the rows whose
    target is finite: the same skeletons bitwise; a frame with a missing wrist keeps that arm as in its cluster."""
    for n in (1, 4):
        targets = fitter.keys_[rng.integers(0, len(fitter.keys_), n)] + rng.normal(0, 0.2, (n, 5, 3))
        targets[:, 1:] += targets[:, :1]
        missing = np.concatenate([targets, targets[:1]])
        missing[n, 1] = np.nan  # one more frame, its left wrist untracked: every chain's rows gathered
        every, gathered = fitter.fit_poses(targets), fitter.fit_poses(missing)
        assert np.array_equal(every, gathered[:n])
        assert np.isfinite(gathered[n]).all()
        cluster = fitter.poses_[fitter.select_clusters(missing[n:])[0]] + missing[n, 0]
        k, root, mid, end, mid_sub, end_sub = next(c for c in fitter._chains if c[0] == 1)
        np.testing.assert_array_equal(gathered[n, [mid, end]], cluster[[mid, end]])


def test_one_frame_fit_with_stacked_subtrees_equals_the_chain_by_chain_fit(fitter: BodyFitter, rng: np.random.Generator,
                                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """A one-frame call with every limb target (the reactor's) moves all the limbs' subtrees in one stacked product
    and picks clusters without the missing-joint mask: bitwise the chain-by-chain fit of the same frame inside a
    batch whose other frame misses a wrist (the gathered path), on random, out-of-reach, and degenerate targets (an
    elbow on the shoulder→wrist line: a limb already straight toward its target; a target on its root)."""
    targets = fitter.keys_[rng.integers(0, len(fitter.keys_), 60)] + rng.normal(0, 0.3, (60, 5, 3))
    targets[:, 1:] += targets[:, :1]
    targets[::7, 1:] *= 3.0  # out of reach
    straight = fitter.poses_[0] + targets[1, 0]
    targets[1, 1:] = fitter.layout_.key_joints(straight[None])[0, 1:]  # every limb already at its target
    k, root, mid, end, _, _ = fitter._chains[0]
    targets[2, k] = targets[2, 0] + fitter.poses_[fitter.select_clusters(targets[2:3])[0], root]  # on the root
    used = []
    real = BodyFitter._move_subtrees

    def spy(self: BodyFitter, *args: np.ndarray) -> None:
        used.append(True)
        real(self, *args)

    monkeypatch.setattr(BodyFitter, "_move_subtrees", spy)
    for t in range(len(targets)):
        one = fitter.fit_poses(targets[t:t + 1])
        pair = np.concatenate([targets[t:t + 1], targets[t:t + 1]])
        pair[1, 2] = np.nan  # the second frame's right wrist missing: both frames' chains gathered
        assert np.array_equal(one[0], fitter.fit_poses(pair)[0])
    assert len(used) == len(targets)  # the one-frame calls took the stacked path, the pairs did not
