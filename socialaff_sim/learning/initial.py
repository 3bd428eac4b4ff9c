"""Initial parses for Algorithm 1: equal parts refined by hard-EM (Viterbi) re-segmentation.

Metropolis-Hastings with the paper's local dynamics moves a parse boundary only through
intermediate states (a merge then a split) whose probability is far lower, so from a poor start
the chain stays near it. The initial parses are therefore improved first: starting from |S|
roughly equal intervals per instance, labelled in order, repeat

1. fit every type's grouping (Gibbs inner loop, warm-started) and potentials, the log-normal
   durations and the smoothed start/transition frequencies on the current parses;
2. re-parse every instance by dynamic programming over its atomic intervals
   (:func:`~socialaff_sim.model.segment_dp.best_segmentation`) under those parameters,

until no parse changes or ``rounds`` is reached. Each round can only move the parses toward
higher joint probability under the current parameters (a coordinate ascent), and the result
seeds the chain.

The rounds (and the restructuring candidates' rounds, :mod:`.restructure`) often meet a type's sample set or
grouping again; what follows from them alone is read back from the run's memos (:mod:`.sample_fits`,
:mod:`.polar_table`), bitwise what a new computation gives. The Gibbs loop, which draws, always runs again.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..model.config import AffordanceConfig
from ..model.densities import fit_lognorm, lognorm_logpdf
from ..model.path import fit_path_noise, path_loglik
from ..model.features import IntervalFeatures
from ..model.potentials import TypePotentials, fit_type_potentials, score_polar
from ..model.segment_dp import best_segmentation
from ..model.transitions import count_transitions, smoothed_probs
from .config import LearningConfig
from .gibbs import gibbs_optimize
from .interval_table import IntervalTable
from .likelihood import TypeLikelihood
from .parse import Parse, ParseSpace
from .polar_table import PolarTable
from .sample_fits import SampleFits, SampleFitsStore
from .scorer import lone_grouping

__all__ = ["hard_em_parses"]


def hard_em_parses(
    tracks: Sequence[np.ndarray],
    fps: Sequence[float],
    spaces: Sequence[ParseSpace],
    parses: Sequence[Parse],
    available: np.ndarray,
    S: int,
    acfg: AffordanceConfig,
    lcfg: LearningConfig,
    *,
    rng: np.random.Generator,
    rounds: int,
    groupings: np.ndarray | None = None,
    table: IntervalTable | None = None,
    store: SampleFitsStore | None = None,
    polars: PolarTable | None = None,
) -> list[Parse]:
    """Refine ``parses`` by alternating parameter fits and DP re-segmentation (see module doc).

    ``groupings`` (S, 11) int64 warm-starts the Gibbs inner loop of each type (default: all Null); ``table``
    holds the interval features of ``tracks`` (shared by the caller across calls; default: a new one);
    ``store`` the run's memo of the sample sets' fits (:mod:`.sample_fits`; shared likewise; None: none); ``polars``
    the candidate intervals' polar coordinates (:mod:`.polar_table`; shared likewise; default: a new one)."""
    parses = list(parses)
    if polars is None:
        polars = PolarTable(acfg)
    if table is None:
        table = IntervalTable(tracks, fps, acfg.feature_path_profile)
    n_joints = tracks[0].shape[1] if len(tracks) else 11
    if groupings is None:
        z = [np.where(available, 0, -1).astype(np.int64) for _ in range(S)]
    else:
        z = [np.where(available, np.asarray(g, np.int64), -1) for g in groupings]
    for _ in range(rounds):
        spans = [sp.frame_spans(p) for sp, p in zip(spaces, parses, strict=True)]
        pots, durs, columns = [], [], []
        sigmas = np.full((S, available.shape[0]), np.nan)
        for s in range(S):
            keys = table.type_keys(spans, s)
            feats = table.rows(keys, n_joints)
            if len(feats) == 0:
                pots.append(None)
                durs.append(None)
                columns.append(None)
                continue
            fits = store.of(tuple(keys)) if store is not None else SampleFits()
            if acfg.use_grouping:
                lik = TypeLikelihood(feats.end, feats.disp, available, acfg, fits)
                z[s] = gibbs_optimize(
                    lik, z[s], beta=acfg.beta, gamma=acfg.gamma, rng=rng,
                    max_sweeps=lcfg.initial_gibbs_sweeps, patience=lcfg.gibbs_patience,
                ).z
            else:
                z[s] = lone_grouping(available)
            zs = z[s]
            pots.append(fits.keep(("potentials", zs.tobytes()), lambda: fit_type_potentials(feats.end, feats.disp, zs, acfg)))
            durs.append(fits.keep("duration", lambda: _duration(feats.seconds, acfg)))
            if acfg.path_noise and feats.path_sq is not None:
                sigmas[s] = fits.keep("path_sigma", lambda: fit_path_noise(feats.path_sq, feats.path_n, acfg.path_sigma_min, available)[0])
            columns.append((fits, zs))
        p_start, p_trans = smoothed_probs(*count_transitions(spans, S), acfg.transition_alpha, acfg.distinct_neighbours, acfg.start_prior)
        with np.errstate(divide="ignore"):
            log_s, log_t = np.log(p_start), np.log(p_trans)
        new = []
        for i, (f, space) in enumerate(zip(fps, spaces, strict=True)):
            b = space.bounds
            B = b.shape[0] - 1
            ia, ib = np.triu_indices(B + 1, k=1)
            feats = table.all_pairs(i, b)
            seg = np.full((B + 1, B + 1, S), -np.inf)
            short = (b[ib] - b[ia]) < acfg.min_subevent_seconds * f
            for s in range(S):
                if pots[s] is None:
                    continue
                fits, zs = columns[s]
                seg[ia, ib, s] = fits.keep(
                    ("column", i, zs.tobytes()), lambda: _column(pots[s], zs, durs[s], sigmas[s], i, feats, short, acfg, polars)  # noqa: B023
                )
            total, rows = best_segmentation(
                seg, log_s, log_t, distinct=space.distinct_neighbours and S > 1, unique=space.max_repeats == 1
            )
            if not rows:
                new.append(parses[len(new)])
                continue
            new.append(Parse(tuple(a for a, _, _ in rows), tuple(s for _, _, s in rows)))
        if new == parses:
            break
        parses = new
    return parses


def _duration(seconds: np.ndarray, acfg: AffordanceConfig) -> tuple[float, float]:
    """(μ, σ) of the log-normal duration fit of one type's intervals (seconds)."""
    ln = fit_lognorm(seconds, sigma_min=acfg.sigma_min)
    return float(ln.mu[0]), float(ln.sigma[0])


def _column(
    pot: TypePotentials,
    z: np.ndarray,
    dur: tuple[float, float],
    sigma: np.ndarray,
    i: int,
    feats: IntervalFeatures,
    short: np.ndarray,
    acfg: AffordanceConfig,
    polars: PolarTable,
) -> np.ndarray:
    """One type's log score of every candidate interval of instance ``i`` (``feats``: all its atom pairs, in
    ``np.triu_indices`` order), −inf where NaN or ``short``: a pure function of the type's fits and the instance.
    :func:`~socialaff_sim.model.potentials.log_spatial` + :func:`~socialaff_sim.model.potentials.log_motion` + the
    duration and path terms, the polar coordinates read from ``polars``."""
    aff = np.flatnonzero(z > 0)
    if aff.size == 0:
        spatial = np.zeros(feats.end.shape[0])
    else:
        h, v, th, corr = polars.spatial(i, z, feats)
        spatial = score_polar(h, v, th, pot.spatial[aff], np.zeros(aff.size, bool))
        if corr is not None:
            spatial = spatial + corr
    used = np.flatnonzero(z >= 0)
    if used.size == 0:
        motion = np.zeros(feats.disp.shape[0])
    else:
        h, v, th, corr = polars.motion(i, used, feats)
        motion = score_polar(h, v, th, pot.motion[used], z[used] == 0)
        if corr is not None:
            motion = motion + corr
    score = (
        spatial
        + motion
        + lognorm_logpdf(feats.seconds, *dur)
        + (np.log(feats.seconds) if acfg.duration_density == "log_seconds" else 0.0)
    )
    if feats.path_sq is not None and feats.path_n is not None:
        score = score + path_loglik(feats.path_sq, feats.path_n, sigma).sum(axis=1)
    return np.where(np.isnan(score) | short, -np.inf, score)
