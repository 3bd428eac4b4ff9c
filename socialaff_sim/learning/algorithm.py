"""Algorithm 1 of the paper: atomic intervals, then Metropolis-Hastings over parses with an inner
Gibbs loop over the joint groupings.

The chain starts from the best (highest log P*) hard-EM refinement of the equal-part parses and of
``LearningConfig.init_starts`` random-fraction splits (our addition; 0 by default), improved by
type-level merge-and-split passes (:mod:`~socialaff_sim.learning.restructure`, our addition).
One outer iteration is a sweep: one MH proposal for every training instance in turn (each
instance's kernel leaves the (tempered) target invariant, so the sweep does too); with
``LearningConfig.temperature`` T₀ > 1 iteration i runs at T_i = T₀^(1 − i/(I − 1)), cooling to 1.
The state with the highest log P* visited is returned (a maximum a posteriori estimate); ``trace``
holds the log P* of the current state after every iteration (entry 0: the initial parse) and
``history`` the proposals and acceptances of every dynamics per iteration
(:func:`~socialaff_sim.learning.history.new_history`), which are also logged.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..model.config import AffordanceConfig
from .atomic import AtomicIntervals, atomic_intervals
from .config import LearningConfig
from .history import new_history, summary_line
from .initial import hard_em_parses
from .interval_table import IntervalTable
from .mh import mh_step
from .parse import Parse, ParseSpace
from .polar_table import PolarTable
from .restructure import restructure
from .sample_fits import SampleFitsStore
from .scorer import AffordanceTarget

__all__ = ["FitProgress", "LearningResult", "learn", "make_spaces", "temperatures"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FitProgress:
    """Where Algorithm 1 stands, passed to a ``callback`` after the start and after every outer iteration."""

    label: str
    """Interaction being learnt (the progress description)."""
    iteration: int
    """Outer MCMC iterations done (0: the initial parse is ready)."""
    iterations: int
    """Outer MCMC iterations in all."""
    log_posterior: float
    """log P* of the chain's current state."""
    best_log_posterior: float
    """Highest log P* visited so far (the state :func:`learn` returns)."""
    acceptance: float
    """Fraction of accepted proposals over the iterations done (0 before the first)."""
    seconds: float
    """Wall-clock seconds since :func:`learn` started."""


def temperatures(cfg: LearningConfig, iterations: int) -> np.ndarray:
    """(iterations,) float64: T_i = T₀^(1 − i/(I − 1)), from ``cfg.temperature`` down to 1 (all 1 when T₀ = 1)."""
    if iterations == 0:
        return np.zeros(0)
    frac = np.arange(iterations) / max(iterations - 1, 1)
    return np.power(float(cfg.temperature), 1.0 - frac)


@dataclass(frozen=True)
class LearningResult:
    """What Algorithm 1 found."""

    parses: tuple[Parse, ...]
    """Best parse of every training instance."""
    start_parses: tuple[Parse, ...]
    """The chain's first state (after the optional hard-EM and restructuring of the equal parts)."""
    spaces: tuple[ParseSpace, ...]
    """The instances' atomic intervals and proposal weights."""
    atoms: AtomicIntervals
    """K-means centroids and atom bounds."""
    grouping: np.ndarray
    """(S, 11) int64 best grouping of every sub-event type."""
    log_posterior: float
    """log P* of the returned state."""
    trace: np.ndarray
    """(iterations + 1,) float64: log P* of the current state after each iteration."""
    acceptance: np.ndarray
    """(iterations,) float64: fraction of accepted proposals in each iteration."""
    moves: dict[str, tuple[int, int]]
    """Per dynamics: (proposed, accepted) counts (a proposal with no admissible choice counts as rejected)."""
    history: dict[str, np.ndarray]
    """Per iteration: log P*, temperature, proposals and acceptances of each dynamics (see
    :func:`~socialaff_sim.learning.history.new_history`)."""
    type_updates: int
    """Inner-loop runs (sub-event types re-fitted)."""
    seconds: dict[str, float]
    """Wall-clock seconds of the stages: "atoms" (K-means), "init" (initial parses and groupings), "mcmc"."""


def make_spaces(atoms: AtomicIntervals, n_labels: int, acfg: AffordanceConfig) -> list[ParseSpace]:
    """One :class:`ParseSpace` per instance with the model's label constraints."""
    return [
        ParseSpace(b, d, n_labels, acfg.distinct_neighbours, 1 if acfg.unique_labels else None)
        for b, d in zip(atoms.bounds, atoms.change, strict=True)
    ]


def _initial_target(
    tracks: Sequence[np.ndarray],
    fps: Sequence[float],
    spaces: list[ParseSpace],
    available: np.ndarray,
    n_labels: int,
    acfg: AffordanceConfig,
    lcfg: LearningConfig,
    rng: np.random.Generator,
) -> AffordanceTarget:
    """The chain's start: the best (highest log P*) of the hard-EM refinements of the equal parts and
    of ``lcfg.init_starts`` Dirichlet-fraction splits (see :class:`LearningConfig`)."""
    table = IntervalTable(tracks, fps, acfg.feature_path_profile)  # every interval's features once per run
    store = SampleFitsStore()  # and every sample set's deterministic fits
    polars = PolarTable(acfg)  # and the candidate intervals' polar coordinates
    if not acfg.use_subevents:
        parses = [Parse((0,), (0,)) for _ in spaces]
        return AffordanceTarget(tracks, fps, spaces, parses, available, n_labels, acfg, lcfg, rng, table, store)
    fractions = [np.full(n_labels, 1.0 / n_labels)]
    if n_labels > 1:
        fractions += [rng.dirichlet(np.full(n_labels, lcfg.init_dirichlet)) for _ in range(lcfg.init_starts)]
    candidates = []
    for k, fr in enumerate(fractions):
        parses = [sp.initial_parse(n_labels) if k == 0 else sp.fraction_parse(fr) for sp in spaces]
        if lcfg.init_rounds and n_labels > 1:
            parses = hard_em_parses(
                tracks, fps, spaces, parses, available, n_labels, acfg, lcfg, rng=rng, rounds=lcfg.init_rounds, table=table, store=store, polars=polars
            )
        candidates.append(AffordanceTarget(tracks, fps, spaces, parses, available, n_labels, acfg, lcfg, rng, table, store))
    start = max(candidates, key=lambda t: t.log_prob)  # the first (equal parts) wins ties
    if lcfg.init_type_passes == 0 or n_labels < 3:
        return start

    warm = start.groupings()

    def refine(ps: list[Parse], rounds: int) -> list[Parse]:
        if rounds == 0:
            return ps
        return hard_em_parses(
            tracks, fps, spaces, ps, available, n_labels, acfg, lcfg, rng=rng, rounds=rounds, groupings=warm, table=table, store=store, polars=polars
        )

    def target(ps: list[Parse]) -> AffordanceTarget:
        return AffordanceTarget(tracks, fps, spaces, ps, available, n_labels, acfg, lcfg, rng, table, store)

    parses, value = restructure(
        spaces, start.parses, n_labels, refine=refine, score=lambda ps: target(ps).log_prob,
        passes=lcfg.init_type_passes, rounds=lcfg.init_type_rounds, screen_rounds=lcfg.init_type_screen_rounds,
    )
    return start if value <= start.log_prob else target(parses)


def learn(
    tracks: Sequence[np.ndarray],
    fps: Sequence[float],
    available: np.ndarray,
    n_labels: int,
    acfg: AffordanceConfig,
    lcfg: LearningConfig,
    *,
    rng: np.random.Generator,
    progress: bool = False,
    desc: str = "fit",
    callback: Callable[[FitProgress], None] | None = None,
) -> LearningResult:
    """Run Algorithm 1 on canonical tracks (each (T_i, 11, 3) metres) of one interaction.

    Progress: a tqdm bar on stderr with ``progress``; ``callback(FitProgress)`` after the initial
    parse and after every outer iteration; the same on this module's logger at INFO level.
    """
    clock = time.perf_counter()
    seconds: dict[str, float] = {}
    logger.info("%s: %d instances; atomic intervals (K-means), then the initial parse", desc, len(tracks))
    atoms = atomic_intervals(
        tracks, fps, available, n_clusters=lcfg.n_clusters, min_frames=lcfg.min_atomic_frames,
        max_seconds=lcfg.max_atomic_seconds, tau=lcfg.velocity_seconds, rng=rng, max_iter=lcfg.kmeans_iterations,
    )
    spaces = make_spaces(atoms, n_labels, acfg)
    seconds["atoms"] = time.perf_counter() - clock
    target = _initial_target(tracks, fps, spaces, available, n_labels, acfg, lcfg, rng)
    target.store = None  # the chain's proposals rarely revisit a sample set: no memo there (bounded memory)
    current = target.log_prob
    seconds["init"] = time.perf_counter() - clock - seconds["atoms"]
    best = (current, tuple(target.parses), target.groupings())
    start_parses = tuple(target.parses)
    iterations = lcfg.iterations if acfg.use_subevents and n_labels > 1 else 0
    trace = [current]
    acceptance = []
    moves = {"split": [0, 0], "merge": [0, 0], "relabel": [0, 0], "shift": [0, 0]}
    history = new_history(iterations, current)
    temps = temperatures(lcfg, iterations)
    history["temperature"][:] = temps
    bar = None

    def report(done: int) -> None:
        rate = float(np.mean(acceptance)) if acceptance else 0.0
        state = FitProgress(desc, done, iterations, float(current), float(best[0]), rate, time.perf_counter() - clock)
        logger.info("%s: iteration %d/%d, log P* %.1f (best %.1f), acceptance %.2f, %.1f s",
                  desc, done, iterations, state.log_posterior, state.best_log_posterior, rate, state.seconds)
        if callback is not None:
            callback(state)

    report(0)
    if progress:
        from tqdm.auto import tqdm  # noqa: PLC0415

        bar = tqdm(total=iterations, desc=desc, unit="it", leave=False)
    try:
        for it in range(iterations):
            accepted = 0
            for i, space in enumerate(spaces):
                step = mh_step(space, i, target.parses[i], current, target, lcfg, rng, temperature=float(temps[it]))
                current, ok = step.log_p, step.accepted
                moves[step.move][0] += 1
                moves[step.move][1] += int(ok)
                history[f"proposed_{step.move}"][it] += 1
                history[f"accepted_{step.move}"][it] += int(ok)
                accepted += int(ok)
                if current > best[0]:
                    best = (current, tuple(target.parses), target.groupings())
            acceptance.append(accepted / max(len(spaces), 1))
            trace.append(current)
            history["log_posterior"][it + 1] = current
            logger.debug("%s iteration %d: T %.3g, log P* %.2f, accepted %d of %d", desc, it, temps[it], current, accepted, len(spaces))
            report(len(acceptance))
            if bar is not None:
                bar.update(1)
                bar.set_postfix(logP=f"{current:.1f}", acc=f"{np.mean(acceptance):.2f}")
    finally:
        if bar is not None:
            bar.close()
    seconds["mcmc"] = time.perf_counter() - clock - seconds["atoms"] - seconds["init"]
    if iterations:
        logger.info("%s: %s", desc, summary_line(history))
    return LearningResult(
        parses=best[1],
        start_parses=start_parses,
        spaces=tuple(spaces),
        atoms=atoms,
        grouping=best[2],
        log_posterior=float(best[0]),
        trace=np.asarray(trace),
        acceptance=np.asarray(acceptance),
        moves={k: (v[0], v[1]) for k, v in moves.items()},
        history=history,
        type_updates=target.n_type_updates,
        seconds=seconds,
    )
