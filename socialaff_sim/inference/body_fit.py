"""Full-body fit: turn five key-joint targets into a whole skeleton.

As in the paper, the training skeletons of the synthesized agent are clustered
by K-means (pose normalized: relative to the base, in the canonical interaction
frame); for a target the cluster whose key joints best match is picked, the
body is translated so its base sits on the base target, and each limb
(shoulder→elbow→wrist, hip→knee→ankle) is rotated by analytic two-bone IK so
the wrist/ankle reaches its target, keeping the bone lengths and bending in the
plane of the cluster's own elbow/knee.

Poses are normalized in the canonical interaction frame shared with the
model (:mod:`socialaff_sim.model.frame`): origin at agent 0's base at the
instance's first frame, dropped onto the floor z = 0; x horizontal from agent
0's base toward agent 1's; z up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._norms import norms
from ..data.skeletons import N_KEY, SkeletonLayout
from ..errors import ModelError, NotFittedError
from ..model.frame import CanonicalFrame, canonical_frame

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..data.interaction import Interaction

__all__ = ["BodyFitConfig", "BodyFitter", "instance_frame", "kmeans", "two_bone_ik"]

_EPS = 1e-12
_EYE3 = np.eye(3)
_EYE3.setflags(write=False)
_NEXT, _AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])  # _cross's component indices


def instance_frame(interaction: Interaction) -> CanonicalFrame:
    """The canonical interaction frame of an instance (:mod:`socialaff_sim.model.frame`).

    Built from both agents' base joints at the first frame only, so it is
    available as soon as one frame of both agents has been observed.
    """
    keys = interaction.key_joints()
    return canonical_frame(keys[0, 0, 0], keys[0, 1, 0])


def kmeans(
    points: np.ndarray, k: int, *, rng: np.random.Generator | None = None, n_iter: int = 50
) -> tuple[np.ndarray, np.ndarray]:
    """Lloyd's K-means on ``points`` (N, D); returns centres (k', D) and labels (N,) int64.

    Initialisation is k-means++ with ``rng``, or, without one, deterministic
    farthest-point seeding from the point nearest the mean. ``k'`` is ``k`` capped at
    the number of distinct points.
    An emptied cluster is re-seeded at the point farthest from its centre.
    """
    x = np.asarray(points, dtype=np.float64)
    n = x.shape[0]
    if n == 0:
        raise ModelError("kmeans: expected at least one point, found none")
    k = max(1, min(int(k), len(np.unique(x, axis=0))))
    sq = np.einsum("nd,nd->n", x, x)

    def dist2(c: np.ndarray) -> np.ndarray:
        return np.maximum(sq[:, None] - 2.0 * x @ c.T + np.einsum("kd,kd->k", c, c)[None], 0.0)

    first = int(rng.integers(n)) if rng is not None else int(np.argmin(((x - x.mean(0)) ** 2).sum(1)))
    centres = [x[first]]
    d2 = dist2(x[first][None])[:, 0]
    for _ in range(1, k):
        if rng is not None and d2.sum() > 0:
            nxt = int(rng.choice(n, p=d2 / d2.sum()))
        else:
            nxt = int(np.argmax(d2))
        centres.append(x[nxt])
        d2 = np.minimum(d2, dist2(x[nxt][None])[:, 0])
    c = np.array(centres)
    labels = np.full(n, -1, dtype=np.int64)
    for _ in range(n_iter):
        d = dist2(c)
        new = np.argmin(d, axis=1)
        counts = np.bincount(new, minlength=k)
        for e in np.flatnonzero(counts == 0):
            own = np.where(counts[new] > 1, d[np.arange(n), new], -1.0)
            far = int(np.argmax(own))
            counts[new[far]] -= 1
            new[far], counts[e] = e, 1
        if np.array_equal(new, labels):
            break
        labels = new
        sums = np.zeros_like(c)
        np.add.at(sums, labels, x)
        c = sums / np.bincount(labels, minlength=k)[:, None]
    return c, labels


@dataclass(frozen=True)
class BodyFitConfig:
    """Settings of the full-body fit."""

    n_clusters: int = 40
    """K [—]: number of K-means pose clusters of the training skeletons."""
    n_iter: int = 50
    """[—]: Lloyd iterations of the K-means."""
    max_frames: int = 20000
    """[frames]: Training frames kept for clustering (an even stride subsample above this)."""


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(T, 3) a × b of (T, 3) or (3,) vectors: the products and differences of ``np.cross``, in its order (the same
    values), without its set-up (the body fit runs once per frame on a stream)."""
    if a.shape == b.shape:  # component i is a[i+1]·b[i+2] − a[i+2]·b[i+1] (indices mod 3): the same products, gathered
        return a[..., _NEXT] * b[..., _AFTER] - a[..., _AFTER] * b[..., _NEXT]
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)



def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(T, 3, 3): the smallest rotation taking unit vectors a (T, 3) onto b (T, 3)."""
    v = _cross(a, b)
    c = np.einsum("td,td->t", a, b)
    vx = np.zeros(a.shape[:-1] + (3, 3))
    vx[..., 0, 1], vx[..., 0, 2], vx[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    vx = vx - np.swapaxes(vx, -1, -2)
    anti = c < -1.0 + 1e-9
    any_anti = bool(anti.any())
    scale = np.where(anti, 0.0, 1.0 / np.where(anti, 1.0, 1.0 + c)) if any_anti else 1.0 / (1.0 + c)
    rot = _EYE3 + vx + (vx @ vx) * scale[..., None, None]
    if any_anti:  # half turn about an axis perpendicular to a
        ax = _cross(a[anti], np.array([1.0, 0.0, 0.0]))
        small = norms(ax) < 1e-6
        ax[small] = _cross(a[anti][small], np.array([0.0, 1.0, 0.0]))
        ax /= norms(ax, keepdims=True)
        rot[anti] = 2.0 * ax[:, :, None] * ax[:, None, :] - np.eye(3)
    return rot


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = norms(v, keepdims=True)
    return v / np.maximum(n, _EPS), n[..., 0]


def _independent(chains: Sequence[tuple[int, int, int, int, np.ndarray, np.ndarray]]) -> bool:
    """Whether no limb chain (key slot, root, mid, end, mid subtree, end subtree) moves another's root, mid or end:
    then the chains can be solved as one stack."""
    moved = [set(c[4].tolist()) | set(c[5].tolist()) for c in chains]
    return all(not set(c[1:4]) & m for i, c in enumerate(chains) for j, m in enumerate(moved) if i != j)


def two_bone_ik(
    root: np.ndarray, mid: np.ndarray, end: np.ndarray, target: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Analytic two-bone IK, vectorized over the leading axis; all arrays (T, 3), metres.

    The root stays; the bone lengths |mid - root| and |end - mid| are kept; the
    new mid lies in the plane through root, target and the old mid (so a target
    in the limb's plane keeps that bend plane). Out of reach, the limb is fully
    stretched (or fully folded) along the root→target line. Returns (mid', end').
    """
    a = norms(mid - root)
    b = norms(end - mid)
    u, d = _unit(target - root)
    pole = mid - root
    v = pole - np.einsum("td,td->t", pole, u)[:, None] * u
    weak = norms(v) < 1e-9 * np.maximum(a, 1.0)
    if weak.any():  # old mid on the root→target line: bend toward the old end, else downward
        alt = end[weak] - root[weak]
        alt = alt - np.einsum("td,td->t", alt, u[weak])[:, None] * u[weak]
        for fallback in (np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0])):
            bad = norms(alt) < 1e-9
            f = fallback - (u[weak] @ fallback)[:, None] * u[weak]
            alt[bad] = f[bad]
        v[weak] = alt
    v, _ = _unit(v)
    dc = np.clip(d, np.abs(a - b), a + b)
    cos_a = np.clip((a * a + dc * dc - b * b) / np.maximum(2.0 * a * dc, _EPS), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a * cos_a)
    new_mid = root + a[:, None] * (cos_a[:, None] * u + sin_a[:, None] * v)
    new_end = root + dc[:, None] * u
    return new_mid, new_end


class BodyFitter:
    """K-means pose clusters of one agent's training skeletons, fitted to key-joint targets.

    Learned attributes: ``layout_``, ``poses_`` (K, J, 3) cluster skeletons relative
    to the base with the mean bone lengths, ``keys_`` (K, 5, 3) their key joints
    (NaN where the layout lacks one), ``bone_lengths_`` (J,) metres (0 at the root).
    """

    def __init__(self, config: BodyFitConfig | None = None) -> None:
        self.config = config or BodyFitConfig()

    # -- learning ------------------------------------------------------------------
    def fit(
        self, skeletons: np.ndarray, layout: SkeletonLayout, *, rng: np.random.Generator | None = None
    ) -> BodyFitter:
        """Cluster training skeletons (N, J, 3), metres, already in the canonical frame.

        Joints finite in fewer than half of the frames (e.g. never tracked) are left
        out (NaN in the cluster poses, their limbs not fitted); frames missing any
        other joint are dropped. ``rng`` seeds k-means++; without it the seeding is
        deterministic.
        """
        sk = np.asarray(skeletons, dtype=np.float64)
        if sk.ndim != 3 or sk.shape[1:] != (layout.n_joints, 3):
            raise ModelError(f"body fit: expected skeletons of shape (N, {layout.n_joints}, 3), found {sk.shape}")
        usable = np.isfinite(sk).all(axis=-1).mean(axis=0) >= 0.5 if len(sk) else np.zeros(layout.n_joints, bool)
        sk = sk[np.isfinite(sk[:, usable]).all(axis=(1, 2))] if usable.any() else sk[:0]
        if len(sk) == 0:
            raise ModelError("body fit: no training frame has all (usually tracked) joints finite")
        sk[:, ~usable] = np.nan
        if len(sk) > self.config.max_frames:
            sk = sk[np.linspace(0, len(sk) - 1, self.config.max_frames).astype(np.int64)]
        base = layout.key_indices[0]
        if base is None:
            raise ModelError(f"body fit: layout {layout.name!r} has no base joint")
        rel = sk - sk[:, base : base + 1]
        bones = layout.bones
        lengths = np.zeros(layout.n_joints)
        lengths[bones[:, 1]] = np.linalg.norm(rel[:, bones[:, 1]] - rel[:, bones[:, 0]], axis=-1).mean(axis=0)
        lengths = np.nan_to_num(lengths)
        centres, _ = kmeans(rel[:, usable].reshape(len(rel), -1), self.config.n_clusters, rng=rng, n_iter=self.config.n_iter)
        full = np.full((len(centres), layout.n_joints, 3), np.nan)
        full[:, usable] = centres.reshape(len(centres), -1, 3)
        poses = self._with_lengths(full, layout, lengths)
        self.layout_ = layout
        self.bone_lengths_ = lengths
        self.poses_ = poses - poses[:, base : base + 1]
        self.keys_ = layout.key_joints(self.poses_)
        self._chains = [c for c in self._limb_chains(layout) if usable[list(c[1:4])].all()]
        self._keys_ok: np.ndarray | None = None  # select_clusters's and _move_subtrees's index arrays, made on first use
        self._stacked: tuple[np.ndarray, ...] | None = None
        self._independent = _independent(self._chains)
        return self

    def fit_interactions(
        self, interactions: Sequence[Interaction], *, agent: int = 1, rng: np.random.Generator | None = None
    ) -> BodyFitter:
        """Fit on every frame of one agent of the given instances, each in its canonical frame."""
        if not interactions:
            raise ModelError("body fit: expected at least one training interaction, found none")
        layout = interactions[0].layout
        frames = []
        for inter in interactions:
            if inter.layout.name != layout.name:
                raise ModelError(
                    f"body fit: all instances must share one layout; found {layout.name!r} and "
                    f"{inter.layout.name!r} ({inter.instance_id})"
                )
            frames.append(instance_frame(inter).to_canonical(inter.filled_joints()[:, agent]))
        return self.fit(np.concatenate(frames), layout, rng=rng)

    @staticmethod
    def _with_lengths(poses: np.ndarray, layout: SkeletonLayout, lengths: np.ndarray) -> np.ndarray:
        """Rebuild (K, J, 3) poses from the root with each bone's direction and the given lengths."""
        parents = layout.parents
        order = [j for j in range(layout.n_joints) if parents[j] < 0]
        for j in order:  # breadth-first: parents before children
            order.extend(c for c, p in enumerate(parents) if p == j)
        out = poses.copy()
        for j in order:
            p = parents[j]
            if p >= 0:
                direction, _ = _unit(poses[:, j] - poses[:, p])
                out[:, j] = out[:, p] + lengths[j] * direction
        return out

    @staticmethod
    def _limb_chains(layout: SkeletonLayout) -> list[tuple[int, int, int, int, np.ndarray, np.ndarray]]:
        """(key slot, root, mid, end, mid-subtree joints, end-subtree joints) of each limb."""
        parents = layout.parents
        children: dict[int, list[int]] = {}
        for c, p in enumerate(parents):
            children.setdefault(p, []).append(c)

        def subtree(j: int) -> list[int]:
            out, stack = [], [j]
            while stack:
                q = stack.pop()
                out.append(q)
                stack.extend(children.get(q, []))
            return out

        chains = []
        for k, end in enumerate(layout.key_indices):
            if k == 0 or end is None:
                continue
            mid = parents[end]
            root = parents[mid] if mid >= 0 else -1
            if mid < 0 or root < 0 or mid == layout.key_indices[0]:
                continue  # no elbow/knee between (e.g. the key5 layout): placed directly
            end_sub = subtree(end)
            mid_sub = [j for j in subtree(mid) if j not in end_sub]
            chains.append((k, root, mid, end, np.array(mid_sub), np.array(end_sub)))
        return chains

    # -- fitting targets -----------------------------------------------------------------
    def _check(self) -> None:
        if not hasattr(self, "poses_"):
            raise NotFittedError("BodyFitter: call fit(...) or fit_interactions(...) before fit_poses(...)")

    def select_clusters(self, key_targets: np.ndarray) -> np.ndarray:
        """(T,) int64: per frame, the cluster whose base-relative key joints best match (T, 5, 3) targets."""
        self._check()
        tg = np.asarray(key_targets, dtype=np.float64)
        rel = tg[:, 1:] - tg[:, :1]
        if getattr(self, "_keys_ok", None) is None:  # the clusters' finite key joints (4,), once: the fit is fixed
            self._keys_ok = np.isfinite(self.keys_[:, 1:]).all(-1).all(0)
        ok = np.isfinite(rel).all(-1) & self._keys_ok[None]
        diff = rel[:, None] - self.keys_[None, :, 1:]
        if not ok.all():  # a key joint missing from the targets or the clusters: it does not count
            diff = np.where(ok[:, None, :, None], diff, 0.0)
        return np.argmin((diff**2).sum(axis=(2, 3)), axis=1)


    def fit_poses(self, key_targets: np.ndarray, frame: CanonicalFrame | None = None) -> np.ndarray:
        """Skeletons (T, J, 3), metres, reaching the key-joint targets (T, 5, 3).

        Targets and output are in the canonical frame, or in world coordinates when
        ``frame`` (the instance's :func:`instance_frame`) is given. A NaN target
        (e.g. a key joint the layout lacks) leaves that limb as in the cluster; the
        base target is required.
        """
        self._check()
        tg = np.asarray(key_targets, dtype=np.float64)
        if tg.ndim != 3 or tg.shape[1:] != (N_KEY, 3):
            raise ModelError(f"body fit: expected key targets of shape (T, {N_KEY}, 3), found {tg.shape}")
        if frame is not None:
            tg = frame.to_canonical(tg)
        if not np.isfinite(tg[:, 0]).all():
            raise ModelError("body fit: the base target (key joint 0) must be finite in every frame")
        poses = self.poses_[self.select_clusters(tg)] + tg[:, None, 0]
        done = {c[0] for c in self._chains}
        # Independent limbs: their two-bone problems stacked into one (the same row-wise arithmetic, a few calls
        # instead of a few per limb; a stream fits one frame at a time); else limb by limb.
        if getattr(self, "_independent", None) is None:  # a fitter saved before the flag existed
            self._independent = _independent(self._chains)
        groups = [self._chains] if self._independent else [[c] for c in self._chains]
        finite = np.isfinite(tg).all(-1)  # (T, 5)
        for chains in groups:
            # Every frame of every chain (a stream's usual call): slices, not gathers of the same rows.
            every = bool(chains) and bool(finite[:, [c[0] for c in chains]].all())
            rows = [slice(None) if every else np.flatnonzero(finite[:, c[0]]) for c in chains]
            if not every and not sum(len(r) for r in rows):  # type: ignore[arg-type]
                continue
            if every:  # the chains' joints by one index array each, chain-major as the concatenation below
                r0, m0, e0, t = (np.swapaxes(x[:, [c[i] for c in chains]], 0, 1).reshape(-1, 3)
                                 for x, i in ((poses, 1), (poses, 2), (poses, 3), (tg, 0)))
            else:
                r0, m0, e0, t = (np.concatenate([poses[r, c[i]] if i < 4 else tg[r, c[0]]
                                                 for c, r in zip(chains, rows, strict=True)]) for i in (1, 2, 3, 4))
            m1, e1 = two_bone_ik(r0, m0, e0, t)
            rot_up = _rotation_between(_unit(m0 - r0)[0], _unit(m1 - r0)[0])
            lower_old = np.einsum("tij,tj->ti", rot_up, e0 - m0)
            rot_lo = _rotation_between(_unit(lower_old)[0], _unit(e1 - m1)[0]) @ rot_up
            if every and len(tg) == 1 and chains is self._chains:  # one frame, every limb (the stream's call)
                self._move_subtrees(poses[0], m0, m1, e0, e1, rot_up, rot_lo)
                continue
            at = np.cumsum([0] + [len(tg) if every else len(r) for r in rows])  # type: ignore[arg-type]
            for (_, _, _, _, mid_sub, end_sub), r, a, b in zip(chains, rows, at[:-1], at[1:], strict=True):
                p = poses if every else poses[r]  # in place when every row is the chain's (the same values)
                if len(mid_sub):
                    p[:, mid_sub] = m1[a:b, None] + np.einsum("tij,tnj->tni", rot_up[a:b], p[:, mid_sub] - m0[a:b, None])
                p[:, end_sub] = e1[a:b, None] + np.einsum("tij,tnj->tni", rot_lo[a:b], p[:, end_sub] - e0[a:b, None])
                if not every:
                    poses[r] = p
        for k, idx in enumerate(self.layout_.key_indices):  # key joints with no limb chain
            if k > 0 and idx is not None and k not in done:
                t = tg[:, k]
                ok = np.isfinite(t).all(-1)
                poses[ok, idx] = t[ok]
        return frame.to_world(poses) if frame is not None else poses

    def _move_subtrees(self, pose: np.ndarray, m0: np.ndarray, m1: np.ndarray, e0: np.ndarray, e1: np.ndarray,
                       rot_up: np.ndarray, rot_lo: np.ndarray) -> None:
        """One frame's limbs moved in place (``pose`` (J, 3)): each chain's mid subtree by ``rot_up`` (C, 3, 3) from m0 (C, 3)
        to m1, its end subtree by ``rot_lo`` from e0 to e1; all (independent) chains at once, chain by chain's products."""
        stacked = getattr(self, "_stacked", None)
        if stacked is None:  # the subtrees' joints and their chain, made once
            pairs = [[(j, k) for k, c in enumerate(self._chains) for j in c[i].tolist()] for i in (4, 5)]
            stacked = self._stacked = tuple(np.array([x[i] for x in xs], dtype=np.int64).reshape(-1) for xs in pairs for i in (0, 1))
        mid_j, mid_c, end_j, end_c = stacked
        if len(mid_j):
            pose[mid_j] = m1[mid_c] + np.einsum("tij,tnj->tni", rot_up[mid_c], (pose[mid_j] - m0[mid_c])[:, None])[:, 0]
        pose[end_j] = e1[end_c] + np.einsum("tij,tnj->tni", rot_lo[end_c], (pose[end_j] - e0[end_c])[:, None])[:, 0]

    def fit_pose(self, key_targets: np.ndarray, frame: CanonicalFrame | None = None) -> np.ndarray:
        """One skeleton (J, 3), metres, for key-joint targets (5, 3); see :meth:`fit_poses`."""
        return self.fit_poses(np.asarray(key_targets, dtype=np.float64)[None], frame)[0]
