"""The NuiSI loader: real recordings, a synthetic two-camera scene with known ground truth, and errors."""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path
from scipy.optimize import minimize_scalar

from socialaff_sim.data import load_dataset
from socialaff_sim.data.nuisi import NuisiConfig, _fit_offset, load_nuisi, read_nuisi_agent
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError, DataError, UnsafePickleError

LAYOUT = get_layout("nuitrack10")
J = {n: i for i, n in enumerate(LAYOUT.joint_names)}
CONTACT = ("clap", "fist_bump", "handshake", "high_five")


# -- real recordings -----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def real():
    return load_nuisi(shared_path("nuisi_v1"))


def test_real_instances_counts_and_shapes(real) -> None:
    ds = real
    assert ds.name == "nuisi" and ds.labels == ("clap", "fist_bump", "handshake", "high_five", "wave")
    per_file = {k[: -len("_instances")]: v for k, v in ds.notes.items() if k.endswith("_instances")}
    assert set(per_file) == {"clap1", "fistbump2", "handshake2", "highfive1", "wave1"}
    assert sum(per_file.values()) == len(ds) == ds.notes["instances"]
    for stem, n in per_file.items():
        assert n == sum(i.instance_id.startswith(stem + "_") for i in ds)
        assert 12 <= n <= 35, stem  # README: about 20-30 repetitions (clap's streams overlap for only ~41 s)
    for inter in ds:
        assert inter.joints.shape == (inter.n_frames, 2, 10, 3) and inter.fps == 10.0
        assert 0.8 <= inter.duration <= 5.0, inter.instance_id
        assert inter.layout.name == "nuitrack10" and not inter.key_available()[3:].any()


def test_real_contact_residuals_are_small(real) -> None:
    for stem in ("clap1", "fistbump2", "handshake2", "highfive1"):
        assert 0.0 < real.notes[f"{stem}_contact_residual_m"] < 0.08, stem
    assert "wave1_contact_residual_m" not in real.notes
    assert str(real.notes["wave1_placement"]).startswith("no contact")


def test_real_right_hands_meet_left_hands_do_not(real) -> None:
    for label in CONTACT:
        close, left_close = [], []
        for inter in real.of_label(label):
            j = inter.joints
            right = np.linalg.norm(j[:, 0, J["right_hand"]] - j[:, 1, J["right_hand"]], axis=-1)
            left = np.linalg.norm(j[:, 0, J["left_hand"]] - j[:, 1, J["left_hand"]], axis=-1)
            close.append(np.nanmin(right) < 0.12)
            left_close.append(np.nanmin(left) < 0.25)
        assert np.mean(close) > 0.9 and not any(left_close), label
    assert not any(k.endswith("_mirrored") for k in real.notes)  # checked: the labels are not mirrored
    assert all(real.notes[f"{s}_active_hands"] == "right/right" for s in ("clap1", "fistbump2", "handshake2", "highfive1", "wave1"))


def test_real_geometry_face_to_face_and_upright(real) -> None:
    for label in real.labels:
        j = np.concatenate([i.joints for i in real.of_label(label)])
        waist0, waist1 = np.nanmedian(j[:, 0, J["waist"]], axis=0), np.nanmedian(j[:, 1, J["waist"]], axis=0)
        np.testing.assert_allclose(waist0, [0, 0, 0.95], atol=0.05)
        assert 0.6 < waist1[1] < 1.3, label  # agent 1 stands in front of agent 0 (who faces +y)
        assert abs(waist1[2] - waist0[2]) < 0.2, label  # fitted height consistent with two standing people
        for a in (0, 1):
            rise = np.nanmedian(j[:, a, J["head"], 2] - j[:, a, J["waist"], 2])
            assert 0.45 < rise < 0.9, (label, a)
        if label == "handshake":
            # Right hands meet only if agent 1 stands towards agent 0's right (+x).
            assert waist1[0] > 0.05


def test_real_untracked_wave_hand_is_invalid(real) -> None:
    j = np.concatenate([i.valid for i in real.of_label("wave")])
    assert j[:, 1, J["left_hand"]].mean() < 0.2  # agent 2's left hand is all zeros in ~97 % of the frames
    assert j[:, :, J["right_hand"]].mean() > 0.95
    for inter in real.of_label("wave"):
        assert np.isnan(inter.joints[~inter.valid]).all()


def test_dispatch_through_dataset_spec() -> None:
    ds = load_dataset(f"nuisi:{shared_path('nuisi_v1')}")
    assert ds.name == "nuisi" and len(ds) > 100


# -- synthetic scene: two cameras, known world ------------------------------------------------------------------
BODY = {  # agent's own frame: faces +y, right = +x, z up, waist at origin
    "head": (0, 0, 0.65), "neck": (0, 0, 0.5), "torso": (0, 0, 0.25), "waist": (0, 0, 0),
    "left_shoulder": (-0.2, 0, 0.45), "left_elbow": (-0.25, 0, 0.2), "left_hand": (-0.25, 0.05, 0.0),
    "right_shoulder": (0.2, 0, 0.45), "right_elbow": (0.25, 0, 0.2), "right_hand": (0.25, 0.05, 0.0),
}
TEMPLATE = np.array([BODY[n] for n in LAYOUT.joint_names], dtype=float)
WAIST = {0: np.array([0.0, 0.0, 1.0]), 1: np.array([0.2, 0.9, 1.05])}
MEET = np.array([0.1, 0.45, 1.15])
REST_S, BUMP_S, REPS = 1.5, 2.0, 6
T0 = 1_656_500_000 * 10**9
TOL = 0.025
"""Metres. Linear resampling of the reach (|MEET − rest| ≈ 0.44 m over a 2 s cosine bump, samples up to
0.19 s apart) errs by at most Δt²/8·max|ẍ| ≈ 1.0 cm, and the contact fit inherits an error of that order."""


def _truth(t: np.ndarray, agent: int, hand: str = "right_hand") -> np.ndarray:
    """(len(t), 10, 3) world joints at seconds ``t``: ``REPS`` reaches of ``hand`` to ``MEET``."""
    body = TEMPLATE if agent == 0 else TEMPLATE * [-1, -1, 1]  # agent 1 faces −y
    out = np.repeat((WAIST[agent] + body)[None], len(t), axis=0)
    tau = np.mod(t - REST_S, REST_S + BUMP_S)
    active = (t >= REST_S) & (t < REST_S + REPS * (REST_S + BUMP_S)) & (tau < BUMP_S)
    s = np.where(active, 0.5 * (1 - np.cos(2 * np.pi * tau / BUMP_S)), 0.0)
    h, e = J[hand], J[hand.replace("hand", "elbow")]
    reach = s[:, None] * (MEET - out[:, h])
    out[:, h] += reach
    out[:, e] += 0.5 * reach
    return out


def _camera(agent: int, pitch_deg: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Camera centre and world->camera rows (x right, y down, z forward) of the camera facing ``agent``."""
    a = np.radians(pitch_deg)
    sign = -1.0 if agent == 0 else 1.0  # camera 0 looks along −y at agent 0, camera 1 along +y
    centre = np.array([0.0, 2.0, 1.3]) if agent == 0 else np.array([0.2, -1.1, 1.3])
    f = np.array([0.0, sign * np.cos(a), -np.sin(a)])
    r = np.cross([0.0, sign, 0.0], [0.0, 0.0, 1.0])  # the camera's right: forward × up
    d = np.cross(f, r)  # down, so that (r, d, f) is right-handed
    return centre, np.stack([r, d, f])


def _write_agent(path: Path, time_cls: type, stamps_ns: np.ndarray, world: np.ndarray, agent: int,
                 swap_labels: bool = False, untracked: np.ndarray | None = None) -> None:
    centre, rows = _camera(agent)
    cam = (world - centre) @ rows.T
    if untracked is not None:
        cam[untracked] = 0.0  # how Nuitrack stores a joint it did not track
    if swap_labels:
        cam = cam[:, [0, 1, 2, 3, 7, 8, 9, 4, 5, 6]]
    frames = np.concatenate([cam, np.tile([0.0, 0.0, 0.0, 1.0], cam.shape[:2] + (1,))], axis=-1)
    stamps = np.empty(len(stamps_ns), dtype=object)
    stamps[:] = [time_cls(int(s // 10**9), int(s % 10**9)) for s in stamps_ns]
    np.savez(path, arr_0=frames, arr_1=stamps)


def _scene(folder: Path, stem: str, time_cls: type, rng: np.random.Generator, *, swap_b: bool = False,
           hand_b: str = "right_hand", zero_left_a: tuple[float, float] | None = None) -> float:
    """Write both agents' files; returns the start of the streams' overlap, seconds after T0."""
    folder.mkdir(parents=True, exist_ok=True)
    duration = REST_S + REPS * (REST_S + BUMP_S) + 1.0
    firsts = []
    for agent, (rate, start) in enumerate(((9.2, 0.0), (6.2, 0.3))):
        t = start + np.cumsum(rng.uniform(0.8, 1.2, size=int(duration * rate)) / rate)
        t = np.round(t[t < duration], 9)
        firsts.append(t[0])
        untracked = None
        if agent == 0 and zero_left_a is not None:
            untracked = np.zeros((len(t), 10), dtype=bool)
            untracked[(t > zero_left_a[0]) & (t < zero_left_a[1]), J["left_hand"]] = True
        _write_agent(folder / f"{stem}_agent{agent + 1}.bag.npz", time_cls, T0 + np.round(t * 1e9).astype(np.int64),
                     _truth(t, agent, "right_hand" if agent == 0 else hand_b), agent,
                     swap_labels=swap_b and agent == 1, untracked=untracked)
    return float(max(firsts))


def _instance_times(inter, overlap_start: float) -> np.ndarray:
    """Seconds after T0 of each frame, from the span the loader writes into ``source``."""
    start, stop = map(float, re.search(r"@ ([\d.]+)-([\d.]+) s", inter.source).groups())
    t = start + np.arange(inter.n_frames) / inter.fps
    np.testing.assert_allclose(t[-1], stop, atol=1e-3)
    return overlap_start + t


def test_synthetic_scene_recovers_the_world(tmp_path: Path, fake_rospy: type, rng: np.random.Generator) -> None:
    t0 = _scene(tmp_path, "handshake9", fake_rospy, rng)
    ds = load_nuisi(tmp_path)
    assert len(ds) == REPS and ds.notes["handshake9_instances"] == REPS
    assert ds.notes["handshake9_contact_residual_m"] < 0.01
    shift = np.array([0.0, 0.0, 0.95 - WAIST[0][2]])  # loader: agent 0's waist at (0, 0, 0.95)
    for inter in ds:
        t = _instance_times(inter, t0)
        for a in (0, 1):
            np.testing.assert_allclose(inter.joints[:, a], _truth(t, a) + shift, atol=TOL)
        assert inter.valid.all()


def test_synthetic_fit_yaw_agrees(tmp_path: Path, fake_rospy: type, rng: np.random.Generator) -> None:
    _scene(tmp_path, "fistbump1", fake_rospy, rng)
    plain = load_nuisi(tmp_path)
    yawed = load_nuisi(tmp_path, dataclasses.replace(NuisiConfig(), fit_yaw=True))
    assert yawed.notes["fistbump1_contact_residual_m"] <= plain.notes["fistbump1_contact_residual_m"] + 1e-12
    for a, b in zip(plain, yawed, strict=True):
        np.testing.assert_allclose(a.joints, b.joints, atol=0.02)


def test_synthetic_mirrored_labels_are_detected_and_swapped(tmp_path: Path, fake_rospy: type, rng) -> None:
    t0 = _scene(tmp_path, "highfive4", fake_rospy, rng, swap_b=True)
    ds = load_nuisi(tmp_path)
    assert "right shoulder on the body's left" in str(ds.notes["highfive4_agent2_mirrored"])
    shift = np.array([0.0, 0.0, 0.95 - WAIST[0][2]])
    for inter in ds:
        np.testing.assert_allclose(inter.joints[:, 1], _truth(_instance_times(inter, t0), 1) + shift, atol=TOL)


def test_synthetic_handshake_with_the_left_hand_is_relabelled(tmp_path: Path, fake_rospy: type, rng) -> None:
    _scene(tmp_path, "handshake5", fake_rospy, rng, hand_b="left_hand")
    ds = load_nuisi(tmp_path)
    assert "met the partner's right" in str(ds.notes["handshake5_agent2_mirrored"])
    assert ds.notes["handshake5_active_hands"] == "right/right"
    for inter in ds:
        d = np.linalg.norm(inter.joints[:, 0, J["right_hand"]] - inter.joints[:, 1, J["right_hand"]], axis=-1)
        assert d.min() < 0.02


def test_synthetic_wave_is_placed_from_the_contact_recordings(tmp_path: Path, fake_rospy: type, rng) -> None:
    _scene(tmp_path, "handshake1", fake_rospy, rng)
    _scene(tmp_path, "wave2", fake_rospy, rng)
    ds = load_nuisi(tmp_path)
    assert "median of 1 contact recordings" in str(ds.notes["wave2_placement"])
    waist = np.concatenate([i.joints[:, 1, J["waist"]] for i in ds.of_label("wave")])
    np.testing.assert_allclose(waist, np.tile(WAIST[1] + [0, 0, 0.95 - WAIST[0][2]], (len(waist), 1)), atol=0.01)
    alone = load_nuisi(tmp_path, dataclasses.replace(NuisiConfig(), contact_labels=()))
    assert "default_separation_m" in str(alone.notes["wave2_placement"])
    np.testing.assert_allclose(np.median(alone.of_label("wave")[0].joints[:, 1, J["waist"]], axis=0),
                               [0.0, 0.9, 0.95], atol=1e-9)


def test_synthetic_untracked_joints_become_invalid(tmp_path: Path, fake_rospy: type, rng) -> None:
    t0 = _scene(tmp_path, "clap7", fake_rospy, rng, zero_left_a=(5.0, 9.0))
    ds = load_nuisi(tmp_path)
    lost = 0
    for inter in ds:
        t = _instance_times(inter, t0)
        inside = (t > 5.0 + 0.25) & (t < 9.0 - 0.25)
        assert not inter.valid[inside, 0, J["left_hand"]].any()
        assert np.isnan(inter.joints[inside, 0, J["left_hand"]]).all()
        outside = (t < 5.0 - 0.25) | (t > 9.0 + 0.25)
        assert inter.valid[outside, 0, J["left_hand"]].all()
        lost += inside.sum()
    assert lost > 0


def test_fit_offset_matches_brute_force_minimisation(rng: np.random.Generator) -> None:
    pb = rng.normal(size=(25, 3))
    theta, t = 0.3, np.array([0.4, -1.2, 0.1])
    c, s = np.cos(theta), np.sin(theta)
    R_true = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    pa = pb @ R_true.T + t + rng.normal(scale=0.02, size=pb.shape)
    R, t_fit, resid = _fit_offset(pa, pb, fit_yaw=True)

    def cost(th: float) -> float:
        Rz = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
        tt = pa.mean(0) - Rz @ pb.mean(0)
        return float(np.mean(np.sum((pa - pb @ Rz.T - tt) ** 2, axis=1)))

    best = minimize_scalar(cost, bounds=(-np.pi, np.pi), method="bounded", options={"xatol": 1e-10})
    np.testing.assert_allclose(np.arctan2(R[1, 0], R[0, 0]), best.x, atol=1e-6)
    np.testing.assert_allclose(resid, np.sqrt(best.fun), atol=1e-9)
    # Translation only: the least squares translation is the mean difference.
    R0, t0, _ = _fit_offset(pa, pb, fit_yaw=False)
    np.testing.assert_allclose(R0, np.eye(3), atol=0)
    np.testing.assert_allclose(t0, (pa - pb).mean(axis=0), atol=1e-12)


# -- errors ----------------------------------------------------------------------------------------------------------
def test_config_is_validated() -> None:
    with pytest.raises(ConfigError, match="activity_low"):
        NuisiConfig(activity_low=0.7, activity_high=0.6)
    with pytest.raises(ConfigError, match="fps"):
        NuisiConfig(fps=0.0)


def test_layout_errors(tmp_path: Path, fake_rospy: type, rng) -> None:
    with pytest.raises(DataError, match="found none"):
        load_nuisi(tmp_path, policy="strict")
    _scene(tmp_path, "dance1", fake_rospy, rng)
    with pytest.raises(DataError, match=r"unknown interaction 'dance'.*'highfive'"):
        load_nuisi(tmp_path, policy="strict")
    (tmp_path / "dance1_agent1.bag.npz").rename(tmp_path / "wave1_agent1.bag.npz")
    with pytest.raises(DataError, match="dance1_agent2.bag.npz: expected the partner file dance1_agent1.bag.npz"):
        load_nuisi(tmp_path, policy="strict")


def _rewrite(path: Path, **arrays: np.ndarray) -> None:
    with np.load(path, allow_pickle=True) as data:  # our own synthetic file
        content = {k: data[k] for k in data.files}
    content.update(arrays)
    np.savez(path, **content)


@pytest.mark.parametrize("change, match", [
    (lambda a0, a1: {"arr_0": a0[:, :9]}, r"'arr_0'.*expected float array \(N, 10, 7\), found float64 \(\d+, 9, 7\)"),
    (lambda a0, a1: {"arr_1": a1[:-1]}, r"'arr_1'.*expected one stamp per frame"),
    (lambda a0, a1: {"arr_1": a1[::-1]}, r"'arr_1'.*strictly increasing time stamps"),
    (lambda a0, a1: {"arr_1": a1.reshape(-1, 1)}, r"'arr_1'.*expected shape \(N,\)"),
])
def test_malformed_agent_files(tmp_path: Path, fake_rospy: type, rng, change, match: str) -> None:
    _scene(tmp_path, "clap1", fake_rospy, rng)
    path = tmp_path / "clap1_agent2.bag.npz"
    with np.load(path, allow_pickle=True) as data:  # our own synthetic file
        a0, a1 = data["arr_0"], data["arr_1"]
    _rewrite(path, **change(a0, a1))
    with pytest.raises(DataError, match=match) as info:
        load_nuisi(tmp_path, policy="strict")
    assert str(path) in str(info.value)


def test_malicious_time_stamps_are_refused_without_running(tmp_path: Path, fake_rospy: type, rng) -> None:
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    _scene(tmp_path, "clap1", fake_rospy, rng)
    path = tmp_path / "clap1_agent1.bag.npz"
    with np.load(path, allow_pickle=True) as data:  # our own synthetic file
        stamps = data["arr_1"]
    stamps[3] = Evil()
    _rewrite(path, arr_1=stamps)
    with pytest.raises(UnsafePickleError, match="forbidden global posix.system"):
        load_nuisi(tmp_path, policy="strict")
    assert not marker.exists()


def test_plain_numeric_stamps_are_accepted(tmp_path: Path, fake_rospy: type, rng) -> None:
    _scene(tmp_path, "clap1", fake_rospy, rng)
    for k in (1, 2):
        path = tmp_path / f"clap1_agent{k}.bag.npz"
        stamps, _ = read_nuisi_agent(path)
        _rewrite(path, arr_1=stamps / 1e9)
    assert len(load_nuisi(tmp_path)) == REPS


def test_truncated_real_file_is_a_data_error(tmp_path: Path) -> None:
    for k in (1, 2):
        shutil.copyfile(shared_path("nuisi_v1", f"clap1_agent{k}.bag.npz"), tmp_path / f"clap1_agent{k}.bag.npz")
    path = tmp_path / "clap1_agent1.bag.npz"
    with open(path, "r+b") as fh:
        fh.truncate(path.stat().st_size // 2)
    with pytest.raises(DataError, match="not a readable") as info:
        load_nuisi(tmp_path, policy="strict")
    assert str(path) in str(info.value)


def test_streams_that_do_not_overlap(tmp_path: Path, fake_rospy: type, rng) -> None:
    _scene(tmp_path, "clap1", fake_rospy, rng)
    path = tmp_path / "clap1_agent2.bag.npz"
    stamps, _ = read_nuisi_agent(path)
    shifted = np.empty(len(stamps), dtype=object)
    shifted[:] = [fake_rospy(int(s // 10**9) + 3600, int(s % 10**9)) for s in stamps]
    _rewrite(path, arr_1=shifted)
    with pytest.raises(DataError, match="overlap"):
        load_nuisi(tmp_path, policy="strict")
