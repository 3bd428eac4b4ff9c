"""Loader for NuiSI v1 (Prasad et al., Humanoids 2022): two Nuitrack cameras, continuous recordings.

Each interaction is a pair ``<interaction>_agent1.bag.npz`` / ``_agent2.bag.npz``:
``arr_0`` (N, 10, 7) per frame and joint x, y, z (metres, the agent's own
camera frame: y down, z depth) and a quaternion; ``arr_1`` (N,) the ROS time
stamps, a pickled object array read only through the restricted unpickler
(never ``np.load(allow_pickle=True)``). Agent 0 is agent 1's file, agent 1 the
other. Labels: clap, fist_bump, handshake, high_five, wave. Layout
``"nuitrack10"`` (no legs).

Processing, with the parameters of :class:`NuisiConfig`:

1. **Common clock.** Both streams (about 6 and 9-10 Hz) are interpolated
   linearly onto ``fps`` over their overlap. A joint is valid at a resampled
   time when it was tracked (not all-zero) in the samples on both sides and
   they are at most ``max_gap_s`` apart; invalid entries are NaN.
2. **Per-agent frame.** Camera (x right, y down, z depth) → x, z, −y (z up);
   levelled by the smallest rotation taking the median waist→neck axis to +z
   (people stand upright on average; this removes the cameras' ~12° pitch).
3. **Facing each other.** Each agent faces its own camera (the hands reach
   towards it), so the agent's forward direction is the horizontal normal of
   the median shoulder line that points towards its camera. Agent 0 is turned
   to face +y, agent 1 to face −y. If the labelled right shoulder is on the
   body's left of that forward direction, the agent's left/right labels are
   mirrored: they are swapped and a note is written.
4. **Handedness in same-hand interactions** (``same_hand_labels``, handshakes):
   if the two agents' active hands (the hand moving most) carry different
   labels, the agent whose active hand is "left" has its labels swapped (note).
5. **Segmentation.** The activity a(t) is the sum over both agents of the
   active hand's distance to the waist, normalised between its 5th and 95th
   percentiles. An instance is a run where a > ``activity_low`` that reaches
   ``activity_high``, widened by ``pad_frames``; runs touching the ends of the
   overlap (cut repetitions) or shorter than ``min_instance_frames`` are dropped.
6. **Placement.** For contact interactions (``contact_labels``) the contact
   frame of each instance is where the two active hands reach furthest
   forward; agent 1's translation (and, with ``fit_yaw``, a yaw) is the least
   squares fit making the two hands coincide over those frames. The RMS
   residual is ``notes["<interaction>_contact_residual_m"]``. Interactions
   without contact (wave) take the median agent-1 offset of the contact
   interactions in the same folder, else ``(0, default_separation_m, 0)``.
   The origin is below agent 0's median waist, with that waist at
   ``waist_height_m`` (no feet are tracked, so the floor is an assumption).

Actors: the recordings publish no actor ids, so each recording gets its own
pair (``"<interaction>/agent1"``, ``"<interaction>/agent2"``): folds are
recording-disjoint, not actor-disjoint.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import ConfigError, DataError, choices
from .dataset import Dataset
from .interaction import MIN_FRAMES, Interaction
from .names import stem_problem
from .nuisi_files import read_nuisi_agent
from .policy import DEFAULT_POLICY, SkippedFiles
from .frames import level_rotation
from .skeletons import get_layout

__all__ = ["NuisiConfig", "load_nuisi", "read_nuisi_agent", "NUISI_LABELS"]

NUISI_LABELS: dict[str, str] = {
    "clap": "clap", "fistbump": "fist_bump", "handshake": "handshake", "highfive": "high_five", "wave": "wave",
}
"""File-name prefix (before the trailing take number) -> interaction label."""

_LAYOUT = get_layout("nuitrack10")
_J = _LAYOUT.n_joints
_HEAD, _NECK, _TORSO, _WAIST = 0, 1, 2, 3
_L_SHO, _L_HAND, _R_SHO, _R_HAND = 4, 6, 7, 9
_SWAP = np.array([0, 1, 2, 3, 7, 8, 9, 4, 5, 6])
"""Joint permutation exchanging left and right."""


@dataclass(frozen=True)
class NuisiConfig:
    """Alignment and segmentation parameters for :func:`load_nuisi` (change with ``dataclasses.replace``)."""

    fps: float = 10.0
    """f_s [Hz]: rate of the common clock both agents are resampled to, Hz."""
    max_gap_s: float = 0.5
    """Δt_max [s]: longest gap between tracked samples bridged by interpolation, seconds."""
    activity_low: float = 0.15
    """θ_lo [—]: normalised hand activity below which the hands are at rest (instance boundary)."""
    activity_high: float = 0.6
    """θ_hi [—]: normalised hand activity an instance must reach."""
    pad_frames: int = 1
    """p [frames]: frames added on each side of an instance (within the recording)."""
    min_instance_frames: int = 8
    """T_min [frames]: shortest instance kept, frames at ``fps``."""
    waist_height_m: float = 0.95
    """h_w [m]: assumed height of agent 0's median waist above the floor, metres."""
    fit_yaw: bool = False
    """[—]: Also fit agent 1's yaw at the contacts (else it is fixed by the facing assumption)."""
    contact_labels: tuple[str, ...] = ("clap", "fist_bump", "handshake", "high_five")
    """[—]: Interactions whose active hands touch; agent 1 is placed from these contacts."""
    same_hand_labels: tuple[str, ...] = ("handshake",)
    """[—]: Interactions done with the same hand by both agents (handedness check)."""
    default_separation_m: float = 0.9
    """d_0 [m]: waist-to-waist distance for contact-free interactions when no contact recording is loaded, metres."""

    def __post_init__(self) -> None:
        checks = {
            "fps": self.fps > 0, "max_gap_s": self.max_gap_s > 0,
            "activity_low": 0 <= self.activity_low < self.activity_high,
            "activity_high": self.activity_high <= 1, "pad_frames": self.pad_frames >= 0,
            "min_instance_frames": self.min_instance_frames >= MIN_FRAMES,
            "waist_height_m": self.waist_height_m > 0, "default_separation_m": self.default_separation_m > 0,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ConfigError(f"NuisiConfig: invalid {bad[0]} = {getattr(self, bad[0])!r} "
                              f"(need fps, max_gap_s > 0, 0 <= activity_low < activity_high <= 1, "
                              f"pad_frames >= 0, min_instance_frames >= {MIN_FRAMES})")


def _resample(stamps: np.ndarray, frames: np.ndarray, times: np.ndarray, max_gap_ns: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, 10, 3) at ``times`` (ns) and validity (T, 10); untracked = all-zero position."""
    pos = frames[..., :3]
    tracked = ~(pos == 0).all(axis=-1) & np.isfinite(pos).all(axis=-1)
    out = np.full((len(times), _J, 3), np.nan)
    valid = np.zeros((len(times), _J), dtype=bool)
    for j in range(_J):
        ts = stamps[tracked[:, j]]
        if len(ts) < 2:
            continue
        k = np.clip(np.searchsorted(ts, times), 1, len(ts) - 1)
        ok = (times >= ts[0]) & (times <= ts[-1]) & (ts[k] - ts[k - 1] <= max_gap_ns)
        for d in range(3):
            out[ok, j, d] = np.interp(times[ok], ts, pos[tracked[:, j], j, d])
        valid[:, j] = ok
    return out, valid


def _rot_z(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _orient(cam: np.ndarray, face_sign: float) -> tuple[np.ndarray, bool]:
    """Camera-frame joints (T, 10, 3) -> levelled, turned to face ``face_sign``·y; returns (joints, mirrored)."""
    world = np.stack([cam[..., 0], cam[..., 2], -cam[..., 1]], axis=-1)
    world = world @ level_rotation(world[:, _NECK] - world[:, _WAIST]).T
    shoulder = np.nanmedian(world[:, _R_SHO] - world[:, _L_SHO], axis=0)
    forward = np.array([-shoulder[1], shoulder[0], 0.0])  # horizontal normal of the shoulder line
    to_camera = -np.nanmedian(world[:, _WAIST], axis=0)
    if forward[:2] @ to_camera[:2] < 0:
        forward = -forward
    right = np.cross(forward, [0.0, 0.0, 1.0])
    mirrored = bool(shoulder @ right < 0)
    angle = np.arctan2(forward[1], forward[0])
    return world @ _rot_z(face_sign * np.pi / 2 - angle).T, mirrored


def _active_hand(joints: np.ndarray) -> int:
    """Index of the hand that moves most relative to the waist (mean |Δ distance|; robust to stuck glitches)."""
    motion = []
    for h in (_L_HAND, _R_HAND):
        steps = np.abs(np.diff(np.linalg.norm(joints[:, h] - joints[:, _WAIST], axis=-1)))
        steps = steps[np.isfinite(steps)]
        motion.append(steps.mean() if len(steps) else 0.0)
    return _L_HAND if motion[0] > motion[1] else _R_HAND


def _segment(activity: np.ndarray, cfg: NuisiConfig) -> list[tuple[int, int]]:
    """Instances [start, stop) where the normalised activity rises from rest to ``activity_high`` and back."""
    if not np.isfinite(activity).any():
        return []
    lo_p, hi_p = np.nanpercentile(activity, [5, 95])
    a = np.nan_to_num((activity - lo_p) / max(hi_p - lo_p, 1e-9), nan=0.0)
    T = len(a)
    above = np.concatenate([[False], a > cfg.activity_low, [False]])
    edges = np.flatnonzero(np.diff(above.astype(np.int8)))
    runs = []
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if a[start:stop].max() < cfg.activity_high or start == 0 or stop == T:
            continue
        s, e = max(start - cfg.pad_frames, 0), min(stop + cfg.pad_frames, T)
        if e - s >= cfg.min_instance_frames:
            runs.append((s, e))
    return runs


def _fit_offset(pa: np.ndarray, pb: np.ndarray, fit_yaw: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """Least squares R (about z), t with pa ≈ R pb + t; returns (R, t, RMS residual in metres)."""
    R = np.eye(3)
    if fit_yaw and len(pa) >= 2:
        a = pa[:, :2] - pa[:, :2].mean(axis=0)
        b = pb[:, :2] - pb[:, :2].mean(axis=0)
        R = _rot_z(np.arctan2(np.sum(b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0]), np.sum(a * b)))
    t = pa.mean(axis=0) - R @ pb.mean(axis=0)
    res = pa - (pb @ R.T + t)
    return R, t, float(np.sqrt(np.mean(np.sum(res**2, axis=1))))


def _pairs(root: Path, skipped: SkippedFiles) -> list[tuple[str, str, Path, Path]]:
    """(stem, label, agent-1 file, agent-2 file) per interaction; unknown names and orphans go to ``skipped``."""
    if not root.is_dir():
        raise DataError("expected a folder of <interaction>_agent1.bag.npz / _agent2.bag.npz pairs", path=root)
    files = {p.name: p for p in SkippedFiles.visible(root)}
    pairs = []
    for name, a1 in files.items():
        m = _PAIR_RE.match(name)
        if m is None or not a1.is_file():
            skipped.skip(a1, "unknown file: expected <interaction>_agent1.bag.npz or <interaction>_agent2.bag.npz")
            continue
        stem, agent = m.group(1), m.group(2)
        partner = f"{stem}_agent{3 - int(agent)}.bag.npz"
        if partner not in files:
            skipped.skip(a1, f"expected the partner file {partner} beside it, found none")
            continue
        if agent == "2":
            continue  # the pair is taken with its agent-1 file
        prefix = re.sub(r"\d+$", "", stem).lower()
        bad_id = stem_problem(f"{stem}_000")  # the instance ids are "<stem>_<k>"
        problem = (f"unknown interaction {prefix!r}; known: {choices(NUISI_LABELS)}" if prefix not in NUISI_LABELS
                   else None if bad_id is None else f"field 'instance_id': {bad_id}")
        if problem is not None:
            skipped.skip(a1, problem)
            skipped.skip(files[partner], problem)
            continue
        pairs.append((stem, NUISI_LABELS[prefix], a1, files[partner]))
    if not pairs:
        raise DataError("expected <interaction>_agent1.bag.npz / _agent2.bag.npz pairs of known interactions "
                        f"({choices(NUISI_LABELS)}), found none", path=root)
    return pairs


_PAIR_RE = re.compile(r"^(.+)_agent([12])\.bag\.npz$")


class _Pair(NamedTuple):
    """One interaction's two agents on the common clock, oriented, before agent 1 is placed."""

    stem: str
    label: str
    paths: tuple[Path, Path]
    joints: list[np.ndarray]  # per agent (T, 10, 3), facing ±y, levelled
    valid: list[np.ndarray]  # per agent (T, 10) bool
    hands: list[int]  # active hand joint index per agent
    segments: list[tuple[int, int]]
    clock: np.ndarray  # (T,) seconds since the start of the overlap


def _align_pair(stem: str, label: str, p1: Path, p2: Path, cfg: NuisiConfig, notes: dict[str, float | str]) -> _Pair:
    """Steps 1-5 of the module docstring for one interaction."""
    (s1, f1), (s2, f2) = read_nuisi_agent(p1), read_nuisi_agent(p2)
    t0, t1 = max(s1[0], s2[0]), min(s1[-1], s2[-1])
    times = np.arange(t0, t1 + 1, int(round(1e9 / cfg.fps)), dtype=np.int64)
    if len(times) < cfg.min_instance_frames:
        raise DataError(f"the two agents' streams overlap for {max(t1 - t0, 0) / 1e9:.2f} s, need at least "
                        f"{cfg.min_instance_frames / cfg.fps:.2f} s", path=p2, field="arr_1")
    agents, valids = [], []
    for k, (stamps, frames, path) in enumerate(((s1, f1, p1), (s2, f2, p2))):
        cam, valid = _resample(stamps, frames, times, cfg.max_gap_s * 1e9)
        if valid[:, [_NECK, _WAIST, _L_SHO, _R_SHO]].sum(axis=0).min() < MIN_FRAMES:
            raise DataError("neck, waist and shoulders are almost never tracked; cannot orient the agent",
                            path=path, field="arr_0")
        joints, mirrored = _orient(cam, 1.0 if k == 0 else -1.0)
        if mirrored:
            joints, valid = joints[:, _SWAP], valid[:, _SWAP]
            notes[f"{stem}_agent{k + 1}_mirrored"] = "left/right labels swapped (right shoulder on the body's left)"
        agents.append(joints)
        valids.append(valid)
    hands = [_active_hand(j) for j in agents]
    if label in cfg.same_hand_labels and hands[0] != hands[1]:
        k = hands.index(_L_HAND)
        agents[k], valids[k], hands[k] = agents[k][:, _SWAP], valids[k][:, _SWAP], _R_HAND
        notes[f"{stem}_agent{k + 1}_mirrored"] = "left/right labels swapped (its 'left' hand met the partner's right)"
    names = {_L_HAND: "left", _R_HAND: "right"}
    notes[f"{stem}_active_hands"] = f"{names[hands[0]]}/{names[hands[1]]}"
    notes[f"{stem}_rates_hz"] = f"{1e9 / np.median(np.diff(s1)):.1f}/{1e9 / np.median(np.diff(s2)):.1f}"
    activity = sum(np.linalg.norm(j[:, h] - j[:, _WAIST], axis=-1) for j, h in zip(agents, hands, strict=True))
    segments = _segment(np.asarray(activity), cfg)
    notes[f"{stem}_instances"] = float(len(segments))
    return _Pair(stem, label, (p1, p2), agents, valids, hands, segments, (times - t0) / 1e9)


def _place(pair: _Pair, cfg: NuisiConfig, offsets: list[np.ndarray],
           notes: dict[str, float | str]) -> tuple[np.ndarray, np.ndarray]:
    """Step 6: agent 0 below its median waist, agent 1 from the contacts (or ``offsets``); appends to ``offsets``."""
    (a, b), (va, vb), (ha, hb) = pair.joints, pair.valid, pair.hands
    waist = np.nanmedian(a[:, _WAIST], axis=0)
    a = a - np.array([waist[0], waist[1], waist[2] - cfg.waist_height_m])
    reach = (a[:, ha, 1] - a[:, _WAIST, 1]) - (b[:, hb, 1] - b[:, _WAIST, 1])  # both hands' forward extension
    both = va[:, ha] & vb[:, hb] & np.isfinite(reach)
    contacts = [s + int(np.argmax(np.where(both[s:e], reach[s:e], -np.inf)))
                for s, e in pair.segments if both[s:e].any()]
    if pair.label in cfg.contact_labels and contacts:
        R, t, resid = _fit_offset(a[contacts, ha], b[contacts, hb], cfg.fit_yaw)
        b = b @ R.T + t
        notes[f"{pair.stem}_contact_residual_m"] = resid
        notes[f"{pair.stem}_placement"] = f"fitted at {len(contacts)} contacts"
        offsets.append(np.nanmedian(b[:, _WAIST], axis=0) - np.nanmedian(a[:, _WAIST], axis=0))
    else:
        off = np.median(offsets, axis=0) if offsets else np.array([0.0, cfg.default_separation_m, 0.0])
        b = b - np.nanmedian(b[:, _WAIST], axis=0) + np.nanmedian(a[:, _WAIST], axis=0) + off
        src = f"median of {len(offsets)} contact recordings" if offsets else "default_separation_m"
        notes[f"{pair.stem}_placement"] = f"no contact: agent 2 waist offset {np.round(off, 3).tolist()} m ({src})"
    return a, b


def load_nuisi(root: str | Path, config: NuisiConfig | None = None, *, policy: str = DEFAULT_POLICY) -> Dataset:
    """Load, align and segment every NuiSI pair under ``root`` as a dataset named ``"nuisi"``.

    Instances: joints (T, 2, 10, 3) float64, metres, z up, one world frame
    (NaN where invalid), at ``config.fps``; ids ``"<interaction>_<k>"``;
    ``source`` names both files and the span in seconds since the streams'
    overlap began. Diagnostics (residuals, instance counts, mirrored labels)
    are in ``notes``. ``policy`` (:mod:`~socialaff_sim.data.policy`): files of an unknown interaction
    (e.g. ``rocket1_agent1.bag.npz``), without a partner, or that fail to load are skipped with one
    warning (``"lenient"``, the default) or stop the load (``"strict"``).
    """
    cfg = config or NuisiConfig()
    notes: dict[str, float | str] = {}
    skipped = SkippedFiles(policy, root)
    pairs = []
    for stem, label, p1, p2 in _pairs(Path(root), skipped):
        with skipped.guard(p1):
            pairs.append(_align_pair(stem, label, p1, p2, cfg, notes))
    if not pairs:
        raise DataError("expected at least one readable pair, found none "
                        f"({'; '.join(f'{p.name}: {r}' for p, r in skipped.files[:3])})", path=root)
    offsets: list[np.ndarray] = []
    placed = {}  # contact interactions first, so that the others can use their offsets
    for pair in sorted(pairs, key=lambda p: p.label not in cfg.contact_labels):
        placed[pair.stem] = _place(pair, cfg, offsets, notes)

    interactions = []
    for pair in pairs:
        joints = np.stack(placed[pair.stem], axis=1)
        valid = np.stack(pair.valid, axis=1)
        joints[~valid] = np.nan
        p1, p2 = pair.paths
        for k, (s, e) in enumerate(pair.segments):
            interactions.append(Interaction(
                label=pair.label, fps=cfg.fps, joints=joints[s:e], joint_names=_LAYOUT.joint_names,
                actors=(f"{pair.stem}/agent1", f"{pair.stem}/agent2"), valid=valid[s:e],
                source=f"{p1} + {p2} @ {pair.clock[s]:.3f}-{pair.clock[e - 1]:.3f} s",
                instance_id=f"{pair.stem}_{k:03d}",
            ))
    skipped.report(notes)
    notes["instances"] = float(len(interactions))
    notes["actors"] = "one id pair per recording (none published): folds are recording-disjoint, not actor-disjoint"
    return Dataset("nuisi", tuple(interactions), notes)
