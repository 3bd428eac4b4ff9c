"""The target of the outer loop: P*(parses) with incremental sufficient statistics.

log P*(G) = Σ_s max_{Z^s} [log p(Z^s) + log p(G_s | Z^s)]       (inner loop, per type)
          + Σ_s Σ_{k: s_k = s} log LogNormal(duration_k; μ_s, σ_s)
          + Σ_i [log p(s_1) + Σ_k log p(s_k | s_{k−1})]
(uniform p(c) is a constant and omitted). Every parameter is at its maximum-likelihood value
for the current parses (with ``AffordanceConfig.likelihood == "held_out"`` each sample is instead
scored under the fit without it; ``vector_density`` and ``duration_density`` choose what the
potentials and the duration prior are densities of); the start and transition frequencies use add-α smoothing,
p(s′ | s) = (n_ss′ + α) / (n_s + α m) with m the number of allowed successors (|S| − 1 when
consecutive labels must differ, else |S|) and p(s) = (n_s + α) / (N + α |S|).

A proposal changes one instance's parse; only the sub-event types whose sample set changes
(the labels of the intervals that differ) are re-fitted and re-run through the Gibbs inner
loop, warm-started from their current best grouping; the other types keep their values.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model.config import AffordanceConfig
from ..model.densities import fit_lognorm, heldout_lognorm
from ..model.grouping import canonical_ids
from ..model.transitions import transition_loglik
from ..model.features import IntervalFeatures
from ..model.path import fit_path_noise
from .config import LearningConfig
from .gibbs import gibbs_optimize
from .interval_table import IntervalTable
from .likelihood import TypeLikelihood
from .parse import Parse, ParseSpace
from .sample_fits import SampleFits, SampleFitsStore

__all__ = ["TypeState", "AffordanceTarget", "duration_loglik", "lone_grouping", "path_term"]


def lone_grouping(available: np.ndarray) -> np.ndarray:
    """(11,) grouping of ablation V1: every available joint affordable and alone in its group."""
    z = np.where(available, np.cumsum(available), -1)
    return z.astype(np.int64)


@dataclass
class TypeState:
    """Current statistics of one sub-event type."""

    lik: TypeLikelihood
    """Memoized likelihood of the type's current samples."""
    z: np.ndarray
    """(11,) int64 best grouping found."""
    potential: float
    """log p(Z^s) + log p(G_s | Z^s) at the best grouping found."""
    duration: float
    """Log-normal log-likelihood of the type's durations (seconds) at the ML parameters."""
    path: float = 0.0
    """Path-noise log-likelihood of the frames inside the type's intervals at the ML σ
    (0 unless ``AffordanceConfig.path_noise``)."""

    @property
    def value(self) -> float:
        """The type's share of log P*."""
        return self.potential + self.duration + self.path


def duration_loglik(seconds: np.ndarray, acfg: AffordanceConfig) -> float:
    """Log-normal log-likelihood of one type's durations (seconds): maximized or held-out
    (``acfg.likelihood``), as a density of seconds or of log seconds (``acfg.duration_density``);
    0 with no samples."""
    if seconds.size == 0:
        return 0.0
    if acfg.likelihood == "held_out":
        ll = float(heldout_lognorm(seconds, sigma_min=acfg.sigma_min)[0])
    else:
        ll = float(fit_lognorm(seconds, sigma_min=acfg.sigma_min).loglik[0])
    if acfg.duration_density == "log_seconds":
        ll += float(np.log(seconds).sum())  # density of log x: x f(x)
    return ll


def path_term(feats: IntervalFeatures, available: np.ndarray, acfg: AffordanceConfig) -> float:
    """Path-noise log-likelihood of one type's interior frames at the ML σ (0 unless ``acfg.path_noise``)."""
    if not acfg.path_noise or len(feats) == 0 or feats.path_sq is None or feats.path_n is None:
        return 0.0
    return float(fit_path_noise(feats.path_sq, feats.path_n, acfg.path_sigma_min, available)[1].sum())


class AffordanceTarget:
    """A :class:`~socialaff_sim.learning.mh.ParseTarget` for the affordance model."""

    def __init__(
        self,
        tracks: Sequence[np.ndarray],
        fps: Sequence[float],
        spaces: Sequence[ParseSpace],
        parses: Sequence[Parse],
        available: np.ndarray,
        n_labels: int,
        acfg: AffordanceConfig,
        lcfg: LearningConfig,
        rng: np.random.Generator,
        table: IntervalTable | None = None,
        store: SampleFitsStore | None = None,
    ) -> None:
        """``table``: the interval features of ``tracks``, shared with other targets of one run (default: a new one);
        ``store``: the run's memo of the sample sets' fits (:mod:`.sample_fits`), shared likewise (None: none)."""
        self.tracks = list(tracks)
        self.fps = [float(f) for f in fps]
        self.spaces = list(spaces)
        self.parses = list(parses)
        self.available = np.asarray(available, bool)
        self.S = int(n_labels)
        self.acfg, self.lcfg, self.rng = acfg, lcfg, rng
        self.distinct = spaces[0].distinct_neighbours if spaces else True
        self.spans = [sp.frame_spans(p) for sp, p in zip(self.spaces, self.parses, strict=True)]
        self.table = table if table is not None else IntervalTable(tracks, fps, acfg.feature_path_profile)
        self.store = store
        self.trans = np.zeros((self.S, self.S))
        self.start = np.zeros(self.S)
        for sp in self.spans:
            self._count(sp, +1, self.trans, self.start)
        self.n_type_updates = 0
        """Number of inner-loop runs (type re-fits) so far."""
        init = np.where(self.available, 0, -1).astype(np.int64)
        self.types = [
            self._type_state(s, {}, init, self.lcfg.initial_gibbs_sweeps) for s in range(self.S)
        ]
        self._pending: tuple | None = None

    # -- statistics --------------------------------------------------------------------
    @staticmethod
    def _count(spans: list[tuple[int, int, int]], sign: int, trans: np.ndarray, start: np.ndarray) -> None:
        labels = [s for _, _, s in spans]
        start[labels[0]] += sign
        for a, b in zip(labels, labels[1:]):
            trans[a, b] += sign

    def _samples(self, s: int, override: dict[int, list[tuple[int, int, int]]]) -> tuple[IntervalFeatures, SampleFits]:
        """Features of the intervals labelled ``s`` (as :func:`type_samples`), memoized per interval in the
        run's :class:`~.interval_table.IntervalTable` (a proposal changes one instance, so the other
        instances' rows are look-ups), and the memo of their fits (a new, empty one without a store)."""
        keys = [(i, f0, f1) for i, sp in enumerate(self.spans) for f0, f1, lab in override.get(i, sp) if lab == s]
        fits = self.store.of(tuple(keys)) if self.store is not None else SampleFits()
        return self.table.rows(keys, self.available.shape[0]), fits

    def _type_state(self, s: int, override: dict, z0: np.ndarray, max_sweeps: int) -> TypeState:
        feats, fits = self._samples(s, override)
        lik = TypeLikelihood(feats.end, feats.disp, self.available, self.acfg, fits)
        duration = fits.keep("duration_loglik", lambda: duration_loglik(feats.seconds, self.acfg))
        path = fits.keep("path_term", lambda: path_term(feats, self.available, self.acfg))
        if not self.acfg.use_grouping:
            z = lone_grouping(self.available)
            return TypeState(lik, z, lik.loglik(z), duration, path)
        res = gibbs_optimize(
            lik, z0, beta=self.acfg.beta, gamma=self.acfg.gamma, rng=self.rng,
            max_sweeps=max_sweeps, patience=self.lcfg.gibbs_patience,
        )
        self.n_type_updates += 1
        return TypeState(lik, res.z, res.log_joint, duration, path)

    def _total(self, types: list[TypeState], trans: np.ndarray, start: np.ndarray) -> float:
        t = transition_loglik(start, trans, self.acfg.transition_alpha, self.distinct, self.acfg.start_prior)
        return float(sum(ts.value for ts in types) + t)

    @property
    def log_prob(self) -> float:
        """log P* of the current state."""
        return self._total(self.types, self.trans, self.start)

    def groupings(self) -> np.ndarray:
        """(S, 11) int64: the current best grouping of every type."""
        return np.stack([canonical_ids(ts.z) for ts in self.types])

    # -- ParseTarget -------------------------------------------------------------------
    def propose(self, i: int, parse: Parse) -> float:
        new_spans = self.spaces[i].frame_spans(parse)
        min_frames = self.acfg.min_subevent_seconds * self.fps[i]
        if any(f1 - f0 < min_frames for f0, f1, _ in new_spans):
            self._pending = None
            return -np.inf
        old_spans = self.spans[i]
        touched = sorted({s for _, _, s in set(old_spans) ^ set(new_spans)})
        override = {i: new_spans}
        types = list(self.types)
        for s in touched:
            types[s] = self._type_state(s, override, self.types[s].z, self.lcfg.gibbs_max_sweeps)
        trans, start = self.trans.copy(), self.start.copy()
        self._count(old_spans, -1, trans, start)
        self._count(new_spans, +1, trans, start)
        self._pending = (i, parse, new_spans, types, trans, start)
        return self._total(types, trans, start)

    def accept(self) -> None:
        if self._pending is None:
            return
        i, parse, spans, types, trans, start = self._pending
        self.parses[i] = parse
        self.spans[i] = spans
        self.types, self.trans, self.start = types, trans, start
        self._pending = None

    def reject(self) -> None:
        self._pending = None
