"""Cross-validation splits of one interaction class, named for what they hold apart.

``pair``
    No test (actor A, actor B) pair appears in training (instances grouped by their unordered actor
    pair). The actors themselves may: on SBU actor s01 is tested with s02 and trained on with s03.
``actor``
    No test actor appears in training at all. The actors are dealt to k groups; fold f tests the
    instances whose actors both belong to group f and trains on the instances with no actor of
    group f. An instance whose two actors fall in different groups is tested in no fold (the
    results' ``n_test`` shows how many were), and trains only in the folds that hold out neither
    of its actors. It needs actor ids shared across recordings: where each actor id occurs in one
    recording only (the handovers name actors by recording), a class has fewer than k actors or a
    fold would have no test or no training instance, the split is refused with an error.
``recording``
    No test recording appears in training: instances grouped by their recording
    (:func:`recording_of`). Where every instance is its own recording (SBU, the handovers) this is an
    instance split whose pairs and actors do recur.
``block``
    Within each recording, the instances in time order (dataset order) are cut into k contiguous
    blocks; fold f tests block f of every recording. For data such as NuiSI, where a class is one
    recording of one pair, it is the only split possible. Optimistic: the same people, session and
    camera set-up are in training and test.

Groups (pairs, actors, recordings) are dealt to folds greedily by size after a seeded shuffle,
which balances the folds.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import numpy as np

from ..data.dataset import deal_groups
from ..data.interaction import Interaction
from ..errors import ConfigError, DataError, choices

__all__ = ["OPTIMISTIC_SPLITS", "SPLITS", "make_folds", "recording_of"]

SPLITS: tuple[str, ...] = ("pair", "actor", "recording", "block")
"""Split names; the first is the default."""

OPTIMISTIC_SPLITS: tuple[str, ...] = ("block",)
"""Splits whose tables carry the word "optimistic" (same people and session in training and test)."""

Fold = tuple[np.ndarray, np.ndarray]


def recording_of(interaction: Interaction) -> str:
    """The recording an instance was cut from: its ``source`` up to a time range ``" @ …"`` that loaders
    cutting one continuous recording into instances append (the NuiSI loader does), else the whole source
    (or the instance id when there is no source)."""
    return interaction.source.split(" @ ")[0] if interaction.source else interaction.instance_id


def _from_tests(tests: list[list[int]], n: int) -> list[Fold]:
    return [(np.setdiff1d(np.arange(n), t), np.array(sorted(t), dtype=np.int64)) for t in tests]


def _grouped(keys: Sequence[Hashable], n_folds: int, what: str, groups_name: str, rng: np.random.Generator) -> list[Fold]:
    groups: dict[Hashable, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    if len(groups) < n_folds:
        raise DataError(
            f"{n_folds} {what}-disjoint folds need at least {n_folds} {groups_name}, found {len(groups)}: "
            f"{choices(list(map(str, groups)))}"
        )
    return _from_tests(deal_groups(groups, n_folds, rng), len(keys))


def _actor_folds(insts: Sequence[Interaction], n_folds: int, rng: np.random.Generator) -> list[Fold]:
    recordings: dict[str, set[str]] = {}
    for inter in insts:
        for a in inter.actors:
            recordings.setdefault(a, set()).add(recording_of(inter))
    if all(len(r) == 1 for r in recordings.values()):
        raise DataError(
            "actor split: every actor id occurs in one recording only, so the data carries no actor identities "
            "shared across recordings (use --split pair or recording)"
        )
    actors = sorted(recordings)
    if len(actors) < n_folds:
        raise DataError(f"actor split: {n_folds} folds need at least {n_folds} actors, found {len(actors)}: {choices(actors)}")
    counts = {a: sum(a in inter.actors for inter in insts) for a in actors}
    groups = deal_groups({a: [a] * counts[a] for a in actors}, n_folds, rng)  # dealt by how often they take part
    folds = []
    for f, group in enumerate(groups):
        held = set(group)
        test = [i for i, inter in enumerate(insts) if set(inter.actors) <= held]
        train = [i for i, inter in enumerate(insts) if not held & set(inter.actors)]
        if not test or not train:
            raise DataError(
                f"actor split: fold {f} holds out actors {choices(sorted(held))}, which leaves "
                f"{'no instance with only those actors to test' if not test else 'no training instance without them'} "
                "(use fewer folds, or --split pair)"
            )
        folds.append((np.array(train, dtype=np.int64), np.array(test, dtype=np.int64)))
    return folds


def _block_folds(insts: Sequence[Interaction], n_folds: int) -> list[Fold]:
    by_recording: dict[str, list[int]] = {}
    for i, inter in enumerate(insts):
        by_recording.setdefault(recording_of(inter), []).append(i)
    tests: list[list[int]] = [[] for _ in range(n_folds)]
    for members in by_recording.values():
        if len(members) < n_folds:
            raise DataError(f"block split: {n_folds} blocks need at least {n_folds} instances per recording, found {len(members)}")
        for f, block in enumerate(np.array_split(np.array(members), n_folds)):
            tests[f].extend(int(i) for i in block)
    return _from_tests(tests, len(insts))


def make_folds(insts: Sequence[Interaction], n_folds: int, split: str, *, rng: np.random.Generator) -> list[Fold]:
    """``n_folds`` (train, test) index arrays of ``insts`` (one class) under ``split`` (module docstring).

    Raises :class:`~socialaff_sim.errors.DataError` when the data cannot be split so."""
    if split not in SPLITS:
        raise ConfigError(f"split: expected {choices(SPLITS)}, found {split!r}")
    if n_folds < 2:
        raise ConfigError(f"n_folds: expected at least 2, found {n_folds}")
    if split == "pair":
        return _grouped([tuple(sorted(i.actors)) for i in insts], n_folds, "pair", "actor pairs", rng)
    if split == "recording":
        return _grouped([recording_of(i) for i in insts], n_folds, "recording", "recordings", rng)
    if split == "actor":
        return _actor_folds(insts, n_folds, rng)
    return _block_folds(insts, n_folds)
