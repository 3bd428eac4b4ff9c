"""Cross-validation splits: each one's disjointness property checked by brute force on the fold sets."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from test_evaluation import toy_interaction

from socialaff_sim.data import Dataset, Interaction
from socialaff_sim.data.dataset import actor_disjoint_folds, pair_disjoint_folds
from socialaff_sim.errors import ConfigError, DataError
from socialaff_sim.evaluation import EvaluationConfig, evaluate
from socialaff_sim.evaluation.splits import SPLITS, make_folds, recording_of


def _sbu_like(rng: np.random.Generator) -> list[Interaction]:
    """Seven actors in ordered pairs (as SBU's sets), one to three instances per pair, one recording each."""
    pairs = [("s1", "s2"), ("s1", "s3"), ("s2", "s1"), ("s2", "s3"), ("s3", "s4"), ("s4", "s5"), ("s5", "s6"),
             ("s6", "s7"), ("s7", "s1"), ("s4", "s6"), ("s5", "s7"), ("s3", "s6")]
    out = []
    for p, actors in enumerate(pairs):
        for k in range(int(rng.integers(1, 4))):
            inst = toy_interaction(rng, "push", actors, 10 * p + k, n_frames=14)
            out.append(inst.replace(source=f"/data/{actors[0]}{actors[1]}/{k}.txt"))
    return out


def _continuous(rng: np.random.Generator, n: int = 11) -> list[Interaction]:
    """One pair, one recording cut into n instances (as NuiSI): sources carry the time range after ' @ '."""
    return [
        toy_interaction(rng, "wave", ("rec/agent1", "rec/agent2"), k, n_frames=14).replace(
            source=f"wave_agent1.npz + wave_agent2.npz @ {2.0 * k:.3f}-{2.0 * k + 1.5:.3f} s"
        )
        for k in range(n)
    ]


def _check_partition(folds: list[tuple[np.ndarray, np.ndarray]], n: int, *, tested_once: bool = True) -> None:
    for train, test in folds:
        assert not set(train) & set(test) and len(test) > 0 and len(train) > 0
    tested = np.concatenate([t for _, t in folds])
    assert set(tested.tolist()) == set(range(n))
    if tested_once:
        assert len(tested) == n


@pytest.mark.parametrize("n_folds", [2, 3, 4])
def test_pair_split_holds_every_test_pair_out_of_training(rng: np.random.Generator, n_folds: int) -> None:
    insts = _sbu_like(rng)
    folds = make_folds(insts, n_folds, "pair", rng=np.random.default_rng(5))
    _check_partition(folds, len(insts))
    pair = [frozenset(i.actors) for i in insts]
    for train, test in folds:
        assert not {pair[i] for i in test} & {pair[i] for i in train}
    # …but not the actors: the pair split is not actor-disjoint on this data
    assert any({a for i in test for a in insts[i].actors} & {a for i in train for a in insts[i].actors} for train, test in folds)
    # the old name gives the same folds (it always split by pairs)
    old = actor_disjoint_folds(insts, n_folds, rng=np.random.default_rng(5))
    new = pair_disjoint_folds(insts, n_folds, rng=np.random.default_rng(5))
    for (a, b), (c, d), (e, f) in zip(folds, old, new, strict=True):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, d)
        np.testing.assert_array_equal(a, e)
        np.testing.assert_array_equal(b, f)


@pytest.mark.parametrize("n_folds", [2, 3])
def test_actor_split_holds_every_test_actor_out_of_training(rng: np.random.Generator, n_folds: int) -> None:
    insts = _sbu_like(rng) + [  # every actor with every other: each group has pairs of its own
        toy_interaction(rng, "push", (a, b), 500 + k, n_frames=14).replace(source=f"/data/{a}{b}/x.txt")
        for k, (a, b) in enumerate(itertools.combinations([f"s{i}" for i in range(1, 8)], 2))
    ]
    folds = make_folds(insts, n_folds, "actor", rng=np.random.default_rng(1))
    held_out: list[set[str]] = []
    for train, test in folds:
        test_actors = {a for i in test for a in insts[i].actors}
        train_actors = {a for i in train for a in insts[i].actors}
        assert test_actors and train_actors and not test_actors & train_actors
        # brute force: training is every instance without a test actor; testing, every instance of test actors only
        assert set(train.tolist()) == {i for i in range(len(insts)) if not set(insts[i].actors) & test_actors}
        assert set(test.tolist()) == {i for i in range(len(insts)) if set(insts[i].actors) <= test_actors}
        held_out.append(test_actors)
    # the held-out groups partition the actors
    assert sorted(a for h in held_out for a in h) == [f"s{i}" for i in range(1, 8)]


def test_actor_split_is_refused_where_the_data_has_no_actor_ids(rng: np.random.Generator) -> None:
    # handover-like: the actors are named after their recording, so nothing is shared
    handover = [
        toy_interaction(rng, "hand_over", (f"motion_{k}/giver", f"motion_{k}/receiver"), k, n_frames=14).replace(
            source=f"/data/motion_{k}.pkl")
        for k in range(8)
    ]
    with pytest.raises(DataError, match="no actor identities shared across recordings"):
        make_folds(handover, 4, "actor", rng=rng)
    # NuiSI-like: one recording of one pair per class
    with pytest.raises(DataError, match="no actor identities shared across recordings"):
        make_folds(_continuous(rng), 2, "actor", rng=rng)
    # one pair in two recordings: ids are shared, but two actors cannot make four folds, and holding
    # out one of the two leaves nothing to test or train on
    two = _continuous(rng, 4) + [i.replace(source=f"other.npz @ {k}") for k, i in enumerate(_continuous(rng, 4))]
    with pytest.raises(DataError, match="actor split: 4 folds need at least 4 actors, found 2"):
        make_folds(two, 4, "actor", rng=rng)
    with pytest.raises(DataError, match="leaves no instance with only those actors to test"):
        make_folds(two, 2, "actor", rng=rng)
    # and through the evaluation, as a one-line error naming the class and the flag
    with pytest.raises(ConfigError, match=r"interaction 'wave', --split actor: .*no actor identities"):
        evaluate(Dataset("cont", tuple(_continuous(rng))), ["hold"], config=EvaluationConfig(n_folds=2, split="actor", executor="serial"))


def test_recording_split_and_what_a_recording_is(rng: np.random.Generator) -> None:
    insts = _sbu_like(rng)
    folds = make_folds(insts, 4, "recording", rng=np.random.default_rng(2))
    _check_partition(folds, len(insts))
    for train, test in folds:
        assert not {recording_of(insts[i]) for i in test} & {recording_of(insts[i]) for i in train}
    cont = _continuous(rng)
    assert {recording_of(i) for i in cont} == {"wave_agent1.npz + wave_agent2.npz"}
    with pytest.raises(DataError, match="4 recording-disjoint folds need at least 4 recordings, found 1"):
        make_folds(cont, 4, "recording", rng=rng)


@pytest.mark.parametrize("n", [8, 11])
def test_block_split_cuts_each_recording_into_contiguous_blocks(rng: np.random.Generator, n: int) -> None:
    insts = _continuous(rng, n) + [
        i.replace(source=i.source.replace("wave_", "clap_"), instance_id=f"clap_{k}") for k, i in enumerate(_continuous(rng, 9))
    ]
    folds = make_folds(insts, 4, "block", rng=rng)
    _check_partition(folds, len(insts))
    rec = [recording_of(i) for i in insts]
    for f, (_, test) in enumerate(folds):
        for r in set(rec):
            members = [i for i in range(len(insts)) if rec[i] == r]
            mine = [i for i in test.tolist() if rec[i] == r]
            # contiguous in time order, the f-th of four near-equal blocks
            assert mine == list(range(mine[0], mine[-1] + 1))
            sizes = [len(b) for b in np.array_split(np.arange(len(members)), 4)]
            assert len(mine) == sizes[f] and mine[0] - members[0] == sum(sizes[:f])
    with pytest.raises(DataError, match="at least 4 instances per recording"):
        make_folds(_continuous(rng, 3), 4, "block", rng=rng)


def test_split_names_are_checked(rng: np.random.Generator) -> None:
    assert SPLITS[0] == "pair"
    with pytest.raises(ConfigError, match="split: expected"):
        make_folds(_sbu_like(rng), 2, "instance", rng=rng)
    assert list(itertools.islice(SPLITS, 4)) == ["pair", "actor", "recording", "block"]
