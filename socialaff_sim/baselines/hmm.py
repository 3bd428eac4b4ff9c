"""The paper's multi-level HMM baseline.

Per frame, in the instance's canonical frame (see
:func:`socialaff_sim.inference.body_fit.instance_frame`), the observations are

* the human's skeleton status: K-means cluster of agent 0's pose relative to
  its base (x, y relative to the base, z above the floor);
* the object's status: K-means cluster of the object's position relative to
  agent 0's base (when the class has an object);
* the quantized inter-agent distance: horizontal distance between the bases,
  binned at training quantiles;
* the quantized relative orientation: the bearing of agent 1's base seen from
  agent 0's base, measured from the canonical x axis, binned at quantiles;
* the synthesized agent's status: K-means cluster of agent 1's skeleton
  relative to agent 0's base (so it encodes both the pose and where agent 1
  stands) — observed in training and in the prefix, hidden afterwards.

These feed the :class:`~socialaff_sim.baselines.two_level_hmm.TwoLevelHMM`:
hidden phases form the top level and emit the human's and the object's status;
agent 1's status is a phase-dependent Markov chain at the lower level and
emits the distance and orientation symbols. Prediction filters (z, r) online,
frame by frame, from the human/object symbols and the observed prefix (where
distance, orientation and agent 1's status are observed too); decodes agent 1's
most likely cluster; places the cluster's pose at the distance and bearing
expected under the belief over agent 1's status; and smooths the result
causally with an exponential moving average starting from the last observed
frame. The inferred phase per frame is returned as the sub-event parse.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError, NotFittedError
from ..inference.protocol import Prediction, prediction_from_joints
from ..inference.body_fit import instance_frame, kmeans
from ..model.frame import CanonicalFrame
from .two_level_hmm import TwoLevelHMM

__all__ = ["HMMConfig", "MultiLevelHMM"]


@dataclass(frozen=True)
class HMMConfig:
    """Settings of the HMM baseline.

    The paper gives no numbers; ours were picked by a small grid search on SBU
    (shaking hands, exchanging an object) and the synthetic data (shake hands,
    hand over) under the evaluation protocol: with ~10–20 training instances per
    class, small models generalize best.
    """

    n_phases: int = 4
    """S [—]: hidden phases of the top level."""
    n_agent_clusters: int = 8
    """K_r [—]: status (pose and placement) clusters of the synthesized agent (agent 1)."""
    n_human_clusters: int = 8
    """K_h [—]: pose clusters of the human (agent 0)."""
    n_object_clusters: int = 6
    """K_o [—]: clusters of the object's position relative to the human."""
    n_distance_bins: int = 5
    """K_d [—]: quantization levels of the inter-agent distance."""
    n_orientation_bins: int = 5
    """K_θ [—]: quantization levels of the relative orientation (bearing)."""
    pseudo_count: float = 0.1
    """α [—]: Dirichlet pseudo-count added to every expected count in EM."""
    max_iter: int = 40
    """[—]: Most EM (Baum–Welch) iterations."""
    tol: float = 1e-4
    """[nats/frame]: EM stops when the objective gains less than this per training frame (nats)."""
    smoothing: float = 0.3
    """β [—]: weight of the new frame in the causal exponential smoothing of the output (1 = none)."""


class _Bins:
    """Quantization at training quantiles; each bin's value is the mean of its training values."""

    def __init__(self, values: np.ndarray, k: int) -> None:
        v = values[np.isfinite(values)]
        if v.size == 0:
            raise ModelError("HMM: no finite training value to quantize")
        self.edges = np.unique(np.quantile(v, np.arange(1, k) / k))
        sym = np.searchsorted(self.edges, v)
        n = len(self.edges) + 1
        sums = np.bincount(sym, weights=v, minlength=n)
        counts = np.bincount(sym, minlength=n)
        self.values = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
        self.values = np.where(np.isnan(self.values), np.median(v), self.values)

    @property
    def size(self) -> int:
        return len(self.values)

    def __call__(self, values: np.ndarray) -> np.ndarray:
        out = np.searchsorted(self.edges, np.nan_to_num(values)).astype(np.int64)
        return np.where(np.isfinite(values), out, -1)


class _Clusters:
    """K-means clusters of feature rows, ignoring feature columns that are mostly missing.

    ``columns`` (D,) bool marks the columns used (finite in at least half of the
    training rows); ``full`` (K, D) is each cluster's mean over all columns (NaN
    where a column is never finite in its members).
    """

    def __init__(self, rows: list[np.ndarray], k: int, rng: np.random.Generator) -> None:
        data = np.concatenate(rows)
        self.columns = np.isfinite(data).mean(axis=0) >= 0.5
        used = data[:, self.columns]
        ok = np.isfinite(used).all(axis=1)
        if not self.columns.any() or not ok.any():
            raise ModelError("HMM: no training frame has a complete skeleton/object to cluster")
        self.centres = kmeans(used[ok], k, rng=rng)[0]
        labels = self(data)
        keep = labels >= 0
        sums = np.zeros((len(self.centres), data.shape[1]))
        counts = np.zeros_like(sums)
        np.add.at(sums, labels[keep], np.nan_to_num(data[keep]))
        np.add.at(counts, labels[keep], np.isfinite(data[keep]))
        self.full = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)

    def __len__(self) -> int:
        return len(self.centres)

    def __call__(self, features: np.ndarray) -> np.ndarray:
        """(T,) int64: nearest cluster per row of (T, D) features; −1 where a used column is missing."""
        f = features[:, self.columns]
        ok = np.isfinite(f).all(axis=1)
        out = np.full(len(f), -1, dtype=np.int64)
        if ok.any():
            g, c = f[ok], self.centres
            d = (g**2).sum(1)[:, None] - 2.0 * g @ c.T + (c**2).sum(1)[None]
            out[ok] = np.argmin(d, axis=1)
        return out


@dataclass(frozen=True)
class _Features:
    """Continuous per-frame features of one instance in its canonical frame."""

    frame: CanonicalFrame
    human: np.ndarray  # (T, J*3) agent 0 pose, x/y relative to its base
    agent: np.ndarray  # (T, J, 3) agent 1 skeleton, x/y relative to agent 0's base
    human_base: np.ndarray  # (T, 3)
    obj: np.ndarray | None  # (T, 3) object relative to agent 0's base
    distance: np.ndarray  # (T,) metres
    bearing: np.ndarray  # (T,) radians


def _features(inter: Interaction) -> _Features:
    frame = instance_frame(inter)
    base = inter.layout.key_indices[0]
    if base is None:
        raise ModelError(f"HMM: layout {inter.layout.name!r} has no base joint")
    joints = frame.to_canonical(inter.filled_joints())
    b0, b1 = joints[:, 0, base], joints[:, 1, base]
    flat0 = b0 * np.array([1.0, 1.0, 0.0])
    delta = (b1 - b0)[:, :2]
    obj = None if inter.object is None else frame.to_canonical(inter.object) - b0
    return _Features(
        frame=frame,
        human=(joints[:, 0] - flat0[:, None]).reshape(inter.n_frames, -1),
        agent=joints[:, 1] - flat0[:, None],
        human_base=b0,
        obj=obj,
        distance=np.linalg.norm(delta, axis=1),
        bearing=np.arctan2(delta[:, 1], delta[:, 0]),
    )


class MultiLevelHMM:
    """The multi-level HMM baseline as a :class:`~socialaff_sim.inference.protocol.ReactionMethod`."""

    name = "hmm"

    def __init__(self, config: HMMConfig | None = None) -> None:
        self.config = config or HMMConfig()

    def _symbols(self, f: _Features, n_agent: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Channel symbols (T, C) and agent clusters (T,); agent-1 channels only for t < ``n_agent``."""
        T = len(f.distance)
        cols = [self.human_clusters_(f.human)]
        if self.object_clusters_ is not None:
            cols.append(self.object_clusters_(f.obj) if f.obj is not None else np.full(T, -1))
        cols += [self.distance_bins_(f.distance), self.bearing_bins_(f.bearing)]  # agent channels
        agent = self.agent_clusters_(f.agent.reshape(T, -1))
        x = np.stack(cols, axis=1)
        if n_agent is not None:
            x[n_agent:, -2:] = -1
            agent[n_agent:] = -1
        return x, agent

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> MultiLevelHMM:
        """Cluster and quantize the training frames, then learn the two-level HMM by EM."""
        if not interactions:
            raise ModelError("HMM: expected at least one training interaction, found none")
        cfg = self.config
        feats = [_features(i) for i in interactions]
        self.layout_ = interactions[0].layout
        self.human_clusters_ = _Clusters([f.human for f in feats], cfg.n_human_clusters, rng)
        self.agent_clusters_ = _Clusters([f.agent.reshape(len(f.agent), -1) for f in feats], cfg.n_agent_clusters, rng)
        objs = [f.obj for f in feats if f.obj is not None]
        self.object_clusters_ = _Clusters(objs, cfg.n_object_clusters, rng) if objs else None
        self.distance_bins_ = _Bins(np.concatenate([f.distance for f in feats]), cfg.n_distance_bins)
        self.bearing_bins_ = _Bins(np.concatenate([f.bearing for f in feats]), cfg.n_orientation_bins)
        sizes = [len(self.human_clusters_)]
        if self.object_clusters_ is not None:
            sizes.append(len(self.object_clusters_))
        self.hmm_ = TwoLevelHMM(
            cfg.n_phases,
            len(self.agent_clusters_),
            sizes,
            (self.distance_bins_.size, self.bearing_bins_.size),
            pseudo_count=cfg.pseudo_count,
            max_iter=cfg.max_iter,
            tol=cfg.tol,
        ).fit([self._symbols(f) for f in feats], rng=rng)
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Filter the phase online, decode agent 1's cluster and place it (see the module docstring)."""
        if not hasattr(self, "hmm_"):
            raise NotFittedError("MultiLevelHMM: call fit(...) before predict(...)")
        if interaction.layout.name != self.layout_.name:
            raise ModelError(f"HMM: trained on layout {self.layout_.name!r}, asked for {interaction.layout.name!r}")
        f = _features(interaction)
        T, J = interaction.n_frames, interaction.layout.n_joints
        post = self.hmm_.filter(*self._symbols(f, n_agent=n_observed))
        phase, status = post.sum(axis=2), post.sum(axis=1)
        cluster = np.argmax(status, axis=1)
        dist = status @ (self.hmm_.agent_emit_[0] @ self.distance_bins_.values)
        w = status @ self.hmm_.agent_emit_[1]
        ang = np.arctan2(w @ np.sin(self.bearing_bins_.values), w @ np.cos(self.bearing_bins_.values))
        base_xy = f.human_base[:, :2] + dist[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        skel = self.agent_clusters_.full[cluster].reshape(T, J, 3)
        base = self.layout_.key_indices[0]
        skel[:, :, :2] += (base_xy - skel[:, base, :2])[:, None]
        beta = self.config.smoothing
        last = f.agent[n_observed - 1] + f.human_base[n_observed - 1] * np.array([1.0, 1.0, 0.0])
        for t in range(n_observed, T):
            last = np.where(np.isfinite(last), (1.0 - beta) * last + beta * skel[t], skel[t])
            skel[t] = last
        world = f.frame.to_world(skel)
        return prediction_from_joints(
            interaction, world, n_observed=n_observed, subevents=np.argmax(phase, axis=1).astype(np.int64)
        )
