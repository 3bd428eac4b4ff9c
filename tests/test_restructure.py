"""Type-level merge-and-split moves (socialaff_sim.learning.restructure)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.learning.parse import Parse, ParseSpace
from socialaff_sim.learning.restructure import merge_split, restructure


def _space(n_atoms: int, S: int = 4) -> ParseSpace:
    bounds = np.arange(n_atoms + 1, dtype=np.int64) * 3  # atom a covers frames 3a .. 3a + 2
    return ParseSpace(bounds, np.zeros(n_atoms + 1), S, True, 1)


def test_merge_into_preceding_and_split_in_the_middle() -> None:
    sp = _space(10)
    p = Parse((0, 2, 4, 8), (0, 1, 2, 3))  # atoms 0-1: 0, 2-3: 1, 4-7: 2, 8-9: 3
    out = merge_split(p, sp, b=1, c=2)
    assert out == Parse((0, 4, 6, 8), (0, 2, 1, 3))  # 0 absorbs 1; 2 is cut at atom 6 (frame 18 = its middle)


def test_leading_b_merges_into_its_follower() -> None:
    sp = _space(8)
    p = Parse((0, 3, 5), (1, 0, 2))  # b = 1 comes first
    # 0 takes atoms 0-4; type 2 (atoms 5-7, frames 15-23, middle 19.5) ties between atoms 6 and 7: the first.
    assert merge_split(p, sp, b=1, c=2) == Parse((0, 5, 6), (0, 2, 1))


def test_b_merges_into_c_then_c_is_split_again() -> None:
    sp = _space(8)
    p = Parse((0, 3, 5), (0, 2, 1))  # b = 1 follows c = 2
    assert merge_split(p, sp, b=1, c=2) == Parse((0, 3, 5), (0, 2, 1))
    assert merge_split(Parse((0,), (1,)), sp, b=1, c=2) is None  # nothing to merge into


def test_single_atom_interval_is_not_split() -> None:
    sp = _space(5)
    p = Parse((0, 2, 4), (0, 1, 2))  # type 2 has one atom
    assert merge_split(p, sp, b=1, c=2) == Parse((0, 4), (0, 2))


def test_every_result_is_a_valid_parse_with_the_stated_relabelling(rng: np.random.Generator) -> None:
    sp = _space(9)
    seen = 0
    for _ in range(300):
        cuts = np.sort(rng.choice(np.arange(1, 9), size=int(rng.integers(0, 4)), replace=False))
        labels = tuple(int(v) for v in rng.permutation(4)[: cuts.size + 1])
        p = Parse((0, *map(int, cuts)), labels)
        b, c = (int(v) for v in rng.permutation(4)[:2])
        out = merge_split(p, sp, b, c)
        if out is None:
            continue
        seen += 1
        assert sp.is_valid(out)
        before, after = sp.frame_labels(p), sp.frame_labels(out)
        # Outside b and c, labels stay, except where b's frames joined a neighbour; c's frames become c
        # or b; the new b lies where b or c was (b merged into c and split off again).
        keep = (before != b) & (before != c)
        np.testing.assert_array_equal(after[keep], before[keep])
        assert set(after[before == c].tolist()) <= {b, c}
        assert set(before[after == b].tolist()) <= {b, c}
        if not (before == c).any():
            assert not (after == b).any()
    assert seen > 100


def test_restructure_only_accepts_improvements() -> None:
    spaces = [_space(8), _space(8)]
    start = [Parse((0, 2, 4, 6), (0, 1, 2, 3))] * 2
    target = [Parse((0, 4, 5, 6), (0, 2, 1, 3))] * 2

    def score(ps: list[Parse]) -> float:
        return float(sum((sp.frame_labels(p) == sp.frame_labels(t)).mean()
                         for sp, p, t in zip(spaces, ps, target, strict=True)))

    out, value = restructure(spaces, start, 4, refine=lambda ps, r: ps, score=score, passes=3, rounds=3)
    assert value == pytest.approx(score(out), abs=1e-12)
    assert out == target and value == pytest.approx(2.0, abs=1e-12)
    same, v0 = restructure(spaces, target, 4, refine=lambda ps, r: ps, score=score, passes=3, rounds=3)
    assert same == target and v0 == pytest.approx(2.0, abs=1e-12)
