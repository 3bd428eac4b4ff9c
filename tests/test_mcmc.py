"""The outer loop: parses, the Metropolis-Hastings dynamics and their exact reverse probabilities."""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from itertools import combinations, product

import numpy as np
import pytest

from socialaff_sim.learning.atomic import kmeans, runs_to_atoms, split_long
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.mh import FunctionTarget, mh_step, propose
from socialaff_sim.learning.parse import Parse, ParseSpace, enumerate_parses
from socialaff_sim.model.segment_dp import best_segmentation

SPACES = {
    # name: (bounds, n_labels, distinct_neighbours, max_repeats)
    "free": (np.array([0, 3, 5, 9, 12]), 2, False, None),
    "distinct": (np.array([0, 3, 5, 9, 12, 14]), 2, True, None),
    "unique": (np.array([0, 2, 5, 9, 12, 14]), 3, True, 1),
    "repeats2": (np.array([0, 3, 5, 9, 12]), 2, False, 2),
    # small ones for the fast checks
    "small_distinct": (np.array([0, 3, 5, 9]), 3, True, None),
    "small_unique": (np.array([0, 2, 5, 9, 12]), 3, True, 1),
}


def make_space(name: str) -> ParseSpace:
    bounds, S, distinct, rep = SPACES[name]
    change = np.linspace(0.0, 1.0, bounds.size)[::-1].copy()  # uneven λ-weights
    change[0] = change[-1] = 0.0
    return ParseSpace(bounds, change, S, distinct, rep)


def brute_force_parses(space: ParseSpace) -> set[Parse]:
    out = set()
    A = space.n_atoms
    for m in range(A):
        for cut in combinations(range(1, A), m):
            for labels in product(range(space.n_labels), repeat=m + 1):
                labs = np.array(labels)
                if space.distinct_neighbours and np.any(labs[1:] == labs[:-1]):
                    continue
                if space.max_repeats is not None and np.bincount(labs).max() > space.max_repeats:
                    continue
                out.add(Parse((0, *cut), labels))
    return out


@pytest.mark.parametrize("name", sorted(SPACES))
def test_enumerate_parses(name: str) -> None:
    space = make_space(name)
    parses = list(enumerate_parses(space))
    assert set(parses) == brute_force_parses(space)
    assert len(set(parses)) == len(parses)


def test_parse_frames_and_initial_parse() -> None:
    space = make_space("unique")
    p = Parse((0, 2, 3), (2, 0, 1))
    assert space.frame_spans(p) == [(0, 5, 2), (5, 9, 0), (9, 14, 1)]
    np.testing.assert_array_equal(space.frame_labels(p), [2] * 5 + [0] * 4 + [1] * 5)
    init = space.initial_parse(3)
    assert space.is_valid(init) and init.labels == (0, 1, 2)
    assert not space.is_valid(Parse((0, 2), (1, 1)))


def test_fraction_parse_cuts_at_the_nearest_atom_boundaries() -> None:
    bounds = np.array([0, 3, 5, 9, 12, 20])
    space = ParseSpace(bounds, np.zeros(bounds.size), 3, True, 1)
    # cuts at 0.2 T = 4 (nearest boundary 3 or 5: the first, 3) and 0.7 T = 14 (nearest 12)
    p = space.fraction_parse(np.array([2.0, 5.0, 3.0]))  # normalized: 0.2, 0.5, 0.3
    assert space.frame_spans(p) == [(0, 3, 0), (3, 12, 1), (12, 20, 2)]
    # a part too thin to reach a new boundary collapses; never more parts than labels
    q = space.fraction_parse(np.array([0.5, 0.01, 0.01, 0.48]))
    assert space.is_valid(q) and q.n_intervals <= 3
    assert space.fraction_parse(np.full(3, 1.0 / 3)) == space.initial_parse(3)


def _proposal_table(space: ParseSpace, cfg: LearningConfig, rng: np.random.Generator, n: int):
    """Per state: empirical proposal counts and the (log q forward, log q reverse) of each target."""
    table = {}
    for g in enumerate_parses(space):
        counts: dict[Parse, int] = defaultdict(int)
        logs: dict[Parse, tuple[float, float]] = {}
        for _ in range(n):
            prop = propose(space, g, cfg, rng)
            if prop is None:
                continue
            assert space.is_valid(prop.parse) and prop.parse != g
            counts[prop.parse] += 1
            if prop.parse in logs:  # a given move always reports the same probabilities
                assert logs[prop.parse] == pytest.approx((prop.log_q_forward, prop.log_q_reverse), abs=1e-12)
            logs[prop.parse] = (prop.log_q_forward, prop.log_q_reverse)
        table[g] = (counts, logs)
    return table


def _check_proposals(name: str, p_shift: float, rng: np.random.Generator, n: int) -> None:
    space = make_space(name)
    cfg = dataclasses.replace(LearningConfig(), p_shift=p_shift)
    table = _proposal_table(space, cfg, rng, n)
    for g, (counts, logs) in table.items():
        for g2, c in counts.items():
            q = np.exp(logs[g2][0])
            sd = np.sqrt(q * (1 - q) / n)
            assert abs(c / n - q) <= 5 * sd + 2e-3, (g, g2, c / n, q)
            back = table[g2][1]
            assert g in back, f"reverse move {g2} -> {g} never proposed"
            assert logs[g2][1] == pytest.approx(back[g][0], abs=1e-12)


@pytest.mark.parametrize(("name", "p_shift"), [("small_distinct", 0.0), ("small_unique", 0.5)])
def test_proposal_probabilities_and_reverse_moves(name: str, p_shift: float, rng: np.random.Generator) -> None:
    """Each proposal's log q matches its empirical frequency (within 5 binomial sd), and its claimed
    reverse probability is exactly the forward probability of the reverse move from the new state."""
    _check_proposals(name, p_shift, rng, 1200)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["distinct", "unique", "repeats2"])
@pytest.mark.parametrize("p_shift", [0.0, 0.4])
def test_proposal_probabilities_and_reverse_moves_long(name: str, p_shift: float, rng: np.random.Generator) -> None:
    _check_proposals(name, p_shift, rng, 3000)


def _mh_visits(
    space: ParseSpace, cfg: LearningConfig, rng: np.random.Generator, n: int, seed: int, temperature: float = 1.0,
    scale: float = 1.2,
) -> float:
    """Total variation between the chain's visit frequencies and the exact distribution ∝ exp(log P / T)."""
    parses = list(enumerate_parses(space))
    lw = dict(zip(parses, np.random.default_rng(seed).normal(0, scale, len(parses)), strict=True))
    target = FunctionTarget(lambda ps: lw[ps[0]], [parses[0]])
    p, lp = parses[0], lw[parses[0]]
    counts = dict.fromkeys(parses, 0)
    for _ in range(n):
        p, lp, _, _ = mh_step(space, 0, p, lp, target, cfg, rng, temperature=temperature)
        counts[p] += 1
    w = np.array([lw[q] for q in parses]) / temperature
    exact = np.exp(w - np.logaddexp.reduce(w))
    freq = np.array([counts[q] for q in parses]) / n
    return float(0.5 * np.abs(freq - exact).sum())


def test_mh_chain_matches_exact_posterior(rng: np.random.Generator) -> None:
    """On 4 atoms with |S| = 2 (54 parses) the chain's visit frequencies match the exact posterior.

    Tolerance: total variation ≤ 0.07 after 20 000 steps (seeded; typical 0.03). Dropping the
    reverse-move terms from the acceptance ratio gives about 0.4 on the same problem.
    """
    tv = _mh_visits(make_space("free"), LearningConfig(), rng, 20000, seed=5)
    assert tv <= 0.07, f"total variation {tv:.4f}"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SPACES))
@pytest.mark.parametrize("p_shift", [0.0, 0.5])
@pytest.mark.parametrize("temperature", [1.0, 4.0])
def test_mh_chain_matches_exact_posterior_long(name: str, p_shift: float, temperature: float, rng: np.random.Generator) -> None:
    cfg = dataclasses.replace(LearningConfig(), p_shift=p_shift)
    tv = _mh_visits(make_space(name), cfg, rng, 200000, seed=9, temperature=temperature)
    assert tv <= 0.03, f"total variation {tv:.4f}"


def test_tempered_chain_with_label_swaps_matches_exact_distribution(rng: np.random.Generator) -> None:
    """The default's moves (shift, and relabels that swap labels under one interval per type) at temperature
    T = 3 leave ∝ P^(1/T) invariant: visit frequencies against the enumerated distribution on 4 atoms with
    |S| = 3 and the one-interval constraint. Log targets spread by σ = 3 so that T matters: the untempered
    distribution is ≥ 0.25 away in total variation, and the chain run at T = 1 against the T = 3 target fails."""
    space = make_space("small_unique")
    cfg = dataclasses.replace(LearningConfig(), p_shift=0.3)
    tv = _mh_visits(space, cfg, rng, 30000, seed=3, temperature=3.0, scale=3.0)
    assert tv <= 0.05, f"total variation {tv:.4f}"
    parses = list(enumerate_parses(space))
    w = np.random.default_rng(3).normal(0, 3.0, len(parses))
    p1, p3 = np.exp(w - np.logaddexp.reduce(w)), np.exp(w / 3 - np.logaddexp.reduce(w / 3))
    assert 0.5 * np.abs(p1 - p3).sum() > 0.25


def test_relabel_swaps_under_one_interval_per_type(rng: np.random.Generator) -> None:
    """With every label used once, a relabel swaps two intervals' labels (before: no admissible choice)."""
    from socialaff_sim.learning.mh import propose_move

    space = make_space("small_unique")
    full = Parse((0, 1, 2), (0, 1, 2))
    seen = set()
    for _ in range(300):
        prop = propose_move(space, full, LearningConfig(), rng, "relabel")
        assert prop is not None and space.is_valid(prop.parse)
        assert sorted(prop.parse.labels) == [0, 1, 2] and prop.parse.starts == full.starts
        seen.add(prop.parse.labels)
    assert seen == {(1, 0, 2), (2, 1, 0), (0, 2, 1)}


def test_mh_rejects_impossible_states(rng: np.random.Generator) -> None:
    space = make_space("free")
    start = Parse((0,), (0,))
    target = FunctionTarget(lambda ps: 0.0 if ps[0] == start else -np.inf, [start])
    p, lp = start, 0.0
    for _ in range(200):
        p, lp, accepted, _ = mh_step(space, 0, p, lp, target, LearningConfig(), rng)
        assert p == start and not accepted


# -- dynamic programming over cut points ------------------------------------------------------
@pytest.mark.parametrize("distinct", [False, True])
@pytest.mark.parametrize("unique", [False, True])
def test_best_segmentation_matches_brute_force(distinct: bool, unique: bool, rng: np.random.Generator) -> None:
    for _ in range(8):
        B, S = int(rng.integers(1, 6)), int(rng.integers(1, 4))
        seg = rng.normal(size=(B + 1, B + 1, S))
        ls, lt = rng.normal(size=S), rng.normal(size=(S, S))
        best = -np.inf
        for m in range(B):
            for cut in combinations(range(1, B), m):
                pts = (0, *cut, B)
                for labs in product(range(S), repeat=m + 1):
                    if distinct and any(a == b for a, b in zip(labs, labs[1:])):
                        continue
                    if unique and len(set(labs)) < len(labs):
                        continue
                    v = ls[labs[0]] + sum(lt[a, b] for a, b in zip(labs, labs[1:]))
                    v += sum(seg[pts[k], pts[k + 1], labs[k]] for k in range(m + 1))
                    best = max(best, v)
        total, spans = best_segmentation(seg, ls, lt, distinct=distinct, unique=unique)
        assert total == pytest.approx(best, abs=1e-10) or total == best == -np.inf
        if spans:
            labs = [s for _, _, s in spans]
            again = ls[labs[0]] + sum(lt[a, b] for a, b in zip(labs, labs[1:])) + sum(seg[a, b, s] for a, b, s in spans)
            assert again == pytest.approx(total, abs=1e-10)
            assert spans[0][0] == 0 and spans[-1][1] == B


# -- atomic intervals -------------------------------------------------------------------------
def test_runs_to_atoms_merges_short_runs() -> None:
    labels = np.array([0, 0, 0, 1, 2, 2, 2, 2, 3, 3])
    vectors = np.array([[0.0], [0], [0], [0.9], [1], [1], [1], [1], [5], [5]])
    bounds = runs_to_atoms(labels, vectors, min_frames=2)
    np.testing.assert_array_equal(bounds, [0, 3, 8, 10])  # the lone frame 3 joins the closer run
    assert np.all(np.diff(bounds) >= 2)


def test_split_long_and_kmeans(rng: np.random.Generator) -> None:
    np.testing.assert_array_equal(split_long(np.array([0, 2, 9]), 3), [0, 2, 4, 7, 9])
    x = np.concatenate([rng.normal(0, 0.05, (30, 2)), rng.normal(3, 0.05, (30, 2))])
    c1 = kmeans(x, 2, rng=np.random.default_rng(1))
    c2 = kmeans(x, 2, rng=np.random.default_rng(1))
    np.testing.assert_array_equal(c1, c2)
    np.testing.assert_allclose(np.sort(c1[:, 0]), [0.0, 3.0], atol=0.05)
    assert kmeans(x[:3], 50, rng=rng).shape[0] == 3
