"""A forward (filtering) belief over the running sub-event and its elapsed duration.

The online parse (:mod:`.online_parse`, :mod:`.stream_parse`) keeps the single best parse of the frames
so far (a max-product DP): it commits to one sub-event and one start. :class:`ForwardBelief` keeps instead
the *sum* over every parse on a grid of cut points (every ``stride`` frames) of the same parse score the
DP maximises — start probability, transitions, closed intervals scored by the potentials and their
duration density (:func:`~.online_parse.closed_scores`), the running interval by the survival function of
its duration (:func:`~.online_parse.log_duration_survival`), consecutive labels distinct and, with
``config.unique_labels``, every label used at most once — and reads from it the posterior over the
current sub-event s and its start, i.e. its elapsed duration d.

The recursion (semi-Markov forward algorithm; F is the log weight of "an interval of label s starts at
cut a, mask m of labels used"):

    C(b, m, s)  = logsumexp_a [ F(a, m, s) + seg(a, b, s) ]                    (an interval closes at b)
    F(b, m', s) = logsumexp_{m, s'} [ C(b, m, s') + log p(s | s') ],  m' = m ∪ {s} ∌ s before
    F(0, {s}, s) = log p(s₁ = s)
    P(s, a | frames < t) ∝ Σ_m F(a, m, s) + log P(D_s > (t − a) / fps)

Per cut, the work is over the starts of the last ``horizon`` frames only, and the memory is those starts'
F rows: bounded independently of the time elapsed. Starts older than ``horizon`` frames are merged into
one "long" bucket per label s, treated as begun exactly ``horizon`` frames ago, its set of used labels
forgotten but for s (an approximation that is exact while every sub-event is shorter than ``horizon``
frames; it keeps the mass of a sub-event that lasts instead of dropping it, and with unique labels it lets
a stream of repeated interactions start the sequence of sub-events again, as the windowed DP does at its
window's start). Values are kept up to a common constant (renormalised at every cut).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError, ModelError
from ..model.affordance import AffordanceParameters
from ..model.features import IntervalFeatures
from ..model.path import path_residuals
from . import belief_kernel, belief_scores
from .compiled import KERNELS
from .online_parse import log_duration_survival
from .model_cache import per_model
from .path_sums import PathSums
from .track_window import TrackWindow
from .type_tables import TypeTables

__all__ = ["ForwardBelief"]

_LOG_2PI = float(np.log(2.0 * np.pi))
_max, _sum = np.maximum.reduce, np.add.reduce  # what np.max and ndarray.sum call


class ForwardBelief:
    """Filtering posterior over (current sub-event, elapsed frames) of a growing canonical track."""

    def __init__(self, model: AffordanceParameters, fps: float, *, stride: int, horizon: int, kernel: str = "numpy") -> None:
        """``stride`` [frames]: distance between cut points; ``horizon`` [frames]: longest interval kept
        exactly (rounded up to a multiple of ``stride``); ``kernel``: ``"numpy"`` (the reference) or ``"numba"``, the
        cuts and the posterior by :mod:`~.belief_kernel` (within the tolerance of docs/design.md §7, session 27; with
        the polar type tables and a path profile, else the NumPy cut)."""
        if kernel not in KERNELS:
            raise ConfigError(f"kernel: expected one of {KERNELS}, found {kernel!r}")
        if stride < 1:
            raise ConfigError(f"belief_stride: expected at least 1 frame, found {stride}")
        if horizon < stride:
            raise ConfigError(f"belief_horizon: expected at least belief_stride = {stride} frames, found {horizon}")
        self.model = model
        self.fps = float(fps)
        self.stride = int(stride)
        self.n_starts = -(-int(horizon) // self.stride)
        self.horizon = self.n_starts * self.stride
        self.S = model.n_subevents_
        self.M = 1 << self.S if model.config.unique_labels else 1
        # What depends on the model, the frame rate, the stride and the horizon only: made once per fitted model
        # (model_cache.per_model), read-only, the same arrays for every recording.
        base = per_model(model, ("forward_belief", self.fps, self.stride, self.horizon),
                         lambda: _constants(model, self.fps, self.horizon))
        (self._trans, self._bits, self._surv, self._tables, self._path_use, self._path_c, self._path_2s2, self._into,
         self._from, self._dur, self._short) = base
        # The path terms of the kept starts' intervals from running sums (docs/design.md §7: within a declared
        # tolerance of path_residuals, not bitwise), one row per F row.
        kind = model.config.feature_path_profile
        self._sums = None if kind is None else PathSums(kind, model.available_.shape[0])
        self.kernel = kernel
        self._compiled: tuple | None = None  # the compiled cuts' per-model arrays (kernel "numba")
        if kernel == "numba":
            belief_kernel.load()  # the ConfigError naming the [fast] extra without numba
            sums = self._sums
            if self._tables is not None and sums is not None:
                start = np.asarray(model.log_start_probs_, float)
                self._compiled = per_model(
                    model, ("belief_kernel", self.fps, self.stride, self.horizon),
                    lambda: belief_kernel.constants(self._tables, sums, base, self.horizon, self.stride, start))
        self.reset()

    def reset(self, origin: int = 0) -> None:
        """Start afresh at frame ``origin`` (0: the model's start probabilities; later: a uniform label
        prior, what came before being unknown)."""
        if origin < 0:
            raise ModelError(f"ForwardBelief.reset: expected origin >= 0, found {origin}")
        self.origin = int(origin)
        self._starts = np.zeros(0, np.int64)  # cut frames of the F rows kept, oldest first
        self._F = np.zeros((0, self.M, self.S))
        self._G = np.zeros((0, self.S))  # log Σ_m exp F: what the posterior reads
        self._long = np.full((self.M, self.S), -np.inf)
        self._G_long = np.full(self.S, -np.inf)
        self._has_long = False  # whether the long bucket holds mass (made at each cut, read at every frame)
        self._long_read = self._G_long  # its posterior term at the horizon, G_long + log P(D > horizon)
        self._next = self.origin  # the next cut to process
        if self._sums is not None:
            self._sums.reset()
        self._posterior: tuple[int, np.ndarray, np.ndarray] | None = None  # the last posterior read, until the next cut
        self.cuts = 0
        """Cuts processed since the last reset."""

    @property
    def memory(self) -> int:
        """F rows held (at most ``horizon / stride``): what bounds the per-cut work."""
        return int(self._starts.shape[0])

    def advance(self, track: np.ndarray | TrackWindow, t: int) -> None:
        """Process every cut before frame ``t`` of the canonical ``track`` (≥ t frames, 11, 3; or a window of it,
        read by absolute frame: a frame older than the window is an error). Frames before ``t`` must not change
        between calls (else :meth:`reset`)."""
        if self._compiled is not None:
            if self._next <= t - 1:
                self._compiled_cuts(track, (t - 1 - self._next) // self.stride + 1)
            return
        while self._next <= t - 1:
            self._cut(track, self._next)
            self._next += self.stride

    def _cut(self, track: np.ndarray, b: int) -> None:
        # One np.errstate for the cut's log-sum-exps (log 0 = −inf is expected), np.append's and np.max's work by the
        # calls they make (concatenate, the maximum reduction), C made only when no interval closes: the same values.
        S, M = self.S, self.M
        with np.errstate(divide="ignore"):
            if b == self.origin:
                F = np.full((M, S), -np.inf)
                prior = self.model.log_start_probs_ if b == 0 else np.full(S, -np.log(S))
                if M > 1:
                    F[self._bits, np.arange(S)] = prior
                else:
                    F[0] = prior
            else:
                has_long = self._has_long
                starts = np.concatenate((self._starts, (b - self.horizon,))) if has_long else self._starts
                if starts.size:
                    seg = self._closing(track, starts, b)  # (K, S)
                    C = _lse(self._F + seg[: self._starts.size, None, :], axis=0)
                    if has_long:
                        C = np.logaddexp(C, self._long + seg[-1][None])
                else:
                    C = np.full((M, S), -np.inf)
                V = _lse(C[:, :, None] + self._trans[None], axis=1)  # (M, S): into label s from mask m
                F = np.full((M, S), -np.inf)
                # F[dst[s], s] = V[src[s], s] for every s, as one copy by flat index (_constants)
                F.reshape(-1)[self._into] = V.reshape(-1)[self._from]
            self._starts = np.concatenate((self._starts, (b,)))
            self._F = np.concatenate([self._F, F[None]])
            if self._sums is not None:
                self._sums.add(track, b)
            old = self._starts <= b - self.horizon  # an interval from there to the next cut would exceed the horizon
            if old.any():
                self._long = np.logaddexp(self._long, _lse(self._F[old], axis=0))
                self._starts, self._F = self._starts[~old], self._F[~old]
                if self._sums is not None:
                    self._sums.keep(~old)
                if self.M > 1:  # the long bucket forgets the labels used before it: a stream can start the interaction again
                    merged = _lse(self._long, axis=0)  # (S,)
                    self._long = np.full((self.M, self.S), -np.inf)
                    self._long[self._bits, np.arange(self.S)] = merged
            top = max(float(_max(self._F, axis=None)), float(_max(self._long, axis=None)))
            if np.isfinite(top):  # renormalise: only ratios matter
                self._F -= top
                self._long -= top
            self._G = _lse(self._F, axis=1)
            self._G_long = _lse(self._long, axis=0)
        self._has_long = bool(np.isfinite(self._long).any())
        if self._has_long:
            self._long_read = self._G_long + self._surv[self.horizon]
        self._posterior = None
        self.cuts += 1

    def _compiled_cuts(self, track: np.ndarray | TrackWindow, n: int) -> None:
        """``n`` cuts from the next one in one compiled call (:func:`~.belief_kernel.cuts`): the state of
        :meth:`_cut` and of the path sums, within the tolerance of docs/design.md §7 (session 27)."""
        if isinstance(track, TrackWindow):
            rows, floor = track.rows, track.floor
        else:
            rows, floor = np.ascontiguousarray(track, dtype=float), 0
        sums = self._sums
        assert sums is not None and self._compiled is not None  # internal invariant: set together in __init__
        (self._starts, self._F, self._long, has_long, self._long_read, sums._a, sums._upto, sums._rows, G, G_long,
         done, code, frame) = belief_kernel.cuts(
            rows, floor, self._next, n, self.stride, self.origin, self.horizon, self._starts, self._F, self._long,
            self._has_long, self._long_read, sums._a, sums._upto, sums._rows, *self._compiled)
        sums.starts = self._starts
        self._has_long = bool(has_long)
        if done:
            self._G, self._G_long = G, G_long
        self._next += done * self.stride
        self.cuts += done
        self._posterior = None
        if code != belief_scores.NO_ERROR:
            held = f"frames from {floor} to {floor + rows.shape[0] - 1}"
            raise ModelError(f"ForwardBelief: frame {frame} is read, but the track holds {held}" if code != belief_scores.NO_REPRESENTATIVE
                             else f"ForwardBelief: the long bucket's start {frame} is not a kept start (cuts off the stride grid)")

    def _closing(self, track: np.ndarray, starts: np.ndarray, b: int) -> np.ndarray:
        """(K, S) log scores of the closed intervals [starts, b) (those of
        :func:`~socialaff_sim.inference.online_parse.closed_scores`): they share their last frame, so the
        spatial potentials are evaluated once per type."""
        model = self.model
        feats = self._features(track, starts, b)
        d = b - starts  # frames, ≤ horizon (the cuts are on the stride grid)
        tab = self._tables
        if tab is None:  # the Cartesian densities: the model's own scoring, type by type
            out = np.empty((starts.size, self.S))
            for s in range(self.S):
                spatial = model.log_spatial(s, feats.end[:1])[0]
                out[:, s] = spatial + model.log_motion(s, feats.disp) + model.log_duration(s, feats.seconds)
        else:  # the duration term of d frames from its table (tab.duration(d / fps), made once per model)
            out = tab.spatial(feats.end[:1]) + tab.motion(feats.disp) + self._dur[d]
        if self._sums is None:
            for s in range(self.S):
                out[:, s] += model.log_path(s, feats)
        else:  # model.log_path of every type at once (the path terms are within the tolerance of design.md §7)
            assert feats.path_sq is not None and feats.path_n is not None  # internal invariant: made by _features
            nf = feats.path_n.astype(float)[:, None, None]
            ll = -1.5 * nf * self._path_c[None] - feats.path_sq[:, None, :] / self._path_2s2[None]  # (K, S, J)
            out += np.where(self._path_use[None], ll, 0.0).sum(axis=2)
        out[self._short[d]] = -np.inf  # shorter than min_subevent_seconds
        return out

    def _features(self, track: np.ndarray, starts: np.ndarray, b: int) -> IntervalFeatures:
        """The features of the intervals [starts, b) (those of ``model.interval_features``), their path residuals
        from the running sums of the kept starts (:class:`~.path_sums.PathSums`); ``starts`` are the kept
        ones, then possibly the long bucket's representative start."""
        if self._sums is None:
            x, o = _held(track, starts)
            return self.model.interval_features(x, starts - o, np.full(starts.size, b - o), self.fps)
        sq, n = self._sums.residuals(track, b)
        K = self._starts.size
        if starts.size > K:  # the long bucket's start: that of the oldest kept row (b − horizon), else from the frames
            rep = starts[K:]
            at = np.minimum(np.searchsorted(self._starts, rep), max(K - 1, 0))
            if K and np.array_equal(self._starts[at], rep):
                sq, n = np.concatenate([sq, sq[at]]), np.concatenate([n, n[at]])
            else:
                x, o = _held(track, rep)
                sq_r, n_r = path_residuals(x, rep - o, np.full(rep.size, b - o), self._sums.kind)
                sq, n = np.concatenate([sq, sq_r]), np.concatenate([n, n_r])
        end, disp, seconds = _ends(track, starts, b, self.fps)
        return IntervalFeatures(end, disp, seconds, sq, n)

    def posterior(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """At frame ``t`` (after :meth:`advance` to t): the starts (K,) int64 of the running interval and
        P(start, s | frames < t) (K, S) float64, summing to 1 (the long bucket reported at its
        representative start t − horizon, when it holds mass). Uniform over s at the origin when
        nothing is possible."""
        if self._next <= t - 1:
            raise ModelError(f"ForwardBelief.posterior({t}): advance(track, {t}) first")
        if self._posterior is not None and self._posterior[0] == t:  # read twice at a re-planning frame
            return self._posterior[1], self._posterior[2]
        if self._compiled is not None:
            surv = self._compiled[belief_kernel.SURV]  # the shared read-only table (one compiled specialisation)
            starts, p, possible = belief_kernel.posterior(t, self._starts, self._G, surv, self.horizon,
                                                          self._has_long, self._long_read)
            if not possible:
                starts, p = np.array([self.origin], np.int64), np.full((1, self.S), 1.0 / self.S)
        else:
            starts, p = self._posterior_at(t)
        self._posterior = (t, starts, p)
        return starts, p

    def _posterior_at(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        # Every frame reads this: the reductions by the ufuncs that np.max and ndarray.sum call, without their wrappers.
        starts = self._starts  # every start kept is a cut before t
        d = np.minimum(t - starts, self.horizon)
        logp = self._G + self._surv[d]  # (K, S)
        if self._has_long:
            starts = np.concatenate((starts, (t - self.horizon,)))  # np.append's concatenation
            logp = np.concatenate((logp, self._long_read[None]))
        top = _max(logp, axis=None) if logp.size else -np.inf
        if not np.isfinite(top):
            S = self.S
            return np.array([self.origin], np.int64), np.full((1, S), 1.0 / S)
        p = np.exp(logp - top)
        return starts, p / _sum(p, axis=None)

    def belief(self, t: int) -> np.ndarray:
        """(S,) P(current sub-event = s | frames < t)."""
        return _sum(self.posterior(t)[1], axis=0)


def _constants(model: AffordanceParameters, fps: float, horizon: int) -> tuple:
    """:class:`ForwardBelief`'s model constants (made read-only by :func:`~.model_cache.per_model`): the transitions (S, S) (−inf on the diagonal with
    distinct neighbours), the label bits (S,),
    log P(D_s > d / fps) for d = 0 … ``horizon`` frames (H + 1, S), the type tables (None: Cartesian densities),
    path_loglik's per-type constants (S, J) (None each without a path profile), the flat indices of F and V the
    recursion copies (into label s from mask m: F[m | bit s, s] = V[m, s] for the masks m without s), and per d the duration term (H + 1, S) (None without the tables) and whether d is short (H + 1,)."""
    S = model.n_subevents_
    cfg = model.config
    M = 1 << S if cfg.unique_labels else 1
    trans = np.array(model.log_transitions_, dtype=float)
    if cfg.distinct_neighbours and S > 1:
        np.fill_diagonal(trans, -np.inf)
    bits = 1 << np.arange(S)
    masks = np.arange(M)
    # For every target label s: the source masks that do not hold s, and the masks they become.
    if M > 1:
        src = [masks[(masks & bits[s]) == 0] for s in range(S)]
        dst = [m | bits[s] for s, m in enumerate(src)]
    else:
        src = [masks] * S
        dst = [masks] * S
    d = np.arange(horizon + 1) / fps
    surv = np.stack([log_duration_survival(model, s, d) for s in range(S)], axis=1)  # (H + 1, S)
    tables = TypeTables.of(model) if cfg.vector_density == "polar" else None
    # Per d = 0 … horizon frames: the closed interval's duration term (the tables' duration of d / fps seconds, as the
    # cut computed it) and whether it is too short; and the recursion's F[dst[s], s] = V[src[s], s] by flat index.
    dur = None if tables is None else tables.duration(np.arange(horizon + 1) / float(fps))
    short = np.arange(horizon + 1) < cfg.min_subevent_seconds * fps
    into = np.concatenate([dst[s] * S + s for s in range(S)])
    from_ = np.concatenate([src[s] * S + s for s in range(S)])
    path_use = path_c = path_2s2 = None
    if cfg.feature_path_profile is not None:  # path_loglik's per-type constants, every type at once (S, J)
        sigma = np.asarray(model.path_sigma_, float)
        path_use = np.isfinite(sigma)
        s2 = np.where(path_use, sigma, 1.0) ** 2
        path_c, path_2s2 = _LOG_2PI + np.log(s2), 2.0 * s2
    return trans, bits, surv, tables, path_use, path_c, path_2s2, into, from_, dur, short


def _ends(track: np.ndarray, starts: np.ndarray, b: int, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The end (K, J, 3), displacement (K, J, 3) and seconds (K,) of the intervals [starts, b) (those of
    :func:`~socialaff_sim.model.features.interval_features`)."""
    end = np.repeat(np.asarray(track[b - 1], float)[None], starts.size, axis=0)
    disp = end - track[np.maximum(starts - 1, 0)]
    return end, disp, (b - starts) / float(fps)


def _held(track: np.ndarray | TrackWindow, starts: np.ndarray) -> tuple[np.ndarray, int]:
    """The frames held of ``track`` and the absolute frame of the first (a window's), checked to hold the frame
    before every interval's start (what its features read)."""
    if not isinstance(track, TrackWindow):
        return track, 0
    if track.floor and starts.size and int(starts.min()) - 1 < track.floor:
        raise ModelError(f"ForwardBelief: frame {int(starts.min()) - 1} is read, but the track holds frames from {track.floor} on")
    return track.rows, track.floor


def _lse(x: np.ndarray, axis: int) -> np.ndarray:
    """logsumexp over ``axis`` that returns −inf where every term is −inf, without a warning under the caller's
    ``np.errstate(divide="ignore")`` (the cut's, one for its six log-sum-exps)."""
    top = _max(x, axis=axis, keepdims=True)  # np.max's and np.sum's reductions, without their wrappers
    safe = np.where(np.isfinite(top), top, 0.0)
    return np.log(_sum(np.exp(x - safe), axis=axis)) + np.squeeze(safe, axis=axis)
