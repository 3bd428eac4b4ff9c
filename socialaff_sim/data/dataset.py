"""A dataset: a named collection of interactions, with pair-disjoint folds."""

from __future__ import annotations

from collections import Counter
from collections.abc import Hashable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError, choices
from .interaction import Interaction

__all__ = ["Dataset", "actor_disjoint_folds", "deal_groups", "pair_disjoint_folds"]


@dataclass(frozen=True)
class Dataset:
    """Interactions loaded from one source, in a stable order."""

    name: str
    """Short name of the source (e.g. ``"sbu"``, ``"synthetic"``)."""
    interactions: tuple[Interaction, ...]
    """The instances."""
    notes: Mapping[str, float | str] = field(default_factory=dict)
    """Loader diagnostics worth reporting (e.g. NuiSI alignment residual in metres)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "interactions", tuple(self.interactions))
        ids = [i.instance_id for i in self.interactions]
        dup = [k for k, n in Counter(ids).items() if n > 1]
        if dup:
            raise DataError(f"dataset {self.name!r}: duplicate instance ids {dup[:5]}", field="instance_id")

    def __len__(self) -> int:
        return len(self.interactions)

    def __iter__(self) -> Iterator[Interaction]:
        return iter(self.interactions)

    def __getitem__(self, i: int) -> Interaction:
        return self.interactions[i]

    @property
    def labels(self) -> tuple[str, ...]:
        """Interaction classes present, sorted."""
        return tuple(sorted({i.label for i in self.interactions}))

    def of_label(self, label: str) -> Dataset:
        """The instances of one class; the error lists the classes present."""
        if label not in self.labels:
            raise DataError(f"dataset {self.name!r} has no interaction {label!r}; present: {choices(self.labels)}")
        return Dataset(self.name, tuple(i for i in self.interactions if i.label == label), self.notes)

    def by_id(self, instance_id: str) -> Interaction:
        """Look up one instance by id (a unique prefix or a position index also works)."""
        for i in self.interactions:
            if i.instance_id == instance_id:
                return i
        hits = [i for i in self.interactions if i.instance_id.startswith(instance_id)]
        if len(hits) == 1:
            return hits[0]
        if instance_id.isdigit() and int(instance_id) < len(self.interactions):
            return self.interactions[int(instance_id)]
        some = [i.instance_id for i in self.interactions[:6]]
        raise DataError(
            f"dataset {self.name!r} has no instance {instance_id!r} "
            f"({len(hits)} prefix matches); ids look like {choices(some)}"
        )

    def subset(self, ids: Sequence[str]) -> Dataset:
        """The instances with the given ids, in this dataset's order."""
        keep = set(ids)
        return Dataset(self.name, tuple(i for i in self.interactions if i.instance_id in keep), self.notes)


def deal_groups(groups: Mapping[Hashable, list[int]], n_folds: int, rng: np.random.Generator) -> list[list[int]]:
    """Groups of instance indices dealt to ``n_folds`` folds: after a seeded shuffle, largest group first, each
    to the fold holding the fewest indices so far (balances the fold sizes; a group is never split)."""
    keys = list(groups)
    order = rng.permutation(len(keys))
    keys = sorted((keys[i] for i in order), key=lambda k: -len(groups[k]))
    load = np.zeros(n_folds, dtype=np.int64)
    members: list[list[int]] = [[] for _ in range(n_folds)]
    for k in keys:
        f = int(np.argmin(load))
        members[f].extend(groups[k])
        load[f] += len(groups[k])
    return members


def pair_disjoint_folds(
    interactions: Sequence[Interaction], n_folds: int, *, rng: np.random.Generator
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split into ``n_folds`` (train, test) index arrays whose actor *pairs* are disjoint.

    Instances are grouped by their unordered actor pair, so a test pair never
    appears in training — but its actors may, with other partners: these folds
    are pair-disjoint, not actor-disjoint (for those, and for recording and block
    splits, see :func:`socialaff_sim.evaluation.splits.make_folds`). Groups are
    dealt to folds greedily by size after a seeded shuffle, which balances the
    fold sizes.
    """
    if n_folds < 2:
        raise DataError(f"n_folds: expected at least 2, found {n_folds}")
    groups: dict[tuple[str, ...], list[int]] = {}
    for idx, inter in enumerate(interactions):
        groups.setdefault(tuple(sorted(inter.actors)), []).append(idx)
    if len(groups) < n_folds:
        raise DataError(
            f"n_folds: {n_folds} pair-disjoint folds need at least {n_folds} actor pairs, "
            f"found {len(groups)}: {choices(groups)}"
        )
    members = deal_groups(groups, n_folds, rng)
    n = len(interactions)
    folds = []
    for f in range(n_folds):
        test = np.array(sorted(members[f]), dtype=np.int64)
        train = np.setdiff1d(np.arange(n), test)
        folds.append((train, test))
    return folds


actor_disjoint_folds = pair_disjoint_folds
"""The former, misleading name of :func:`pair_disjoint_folds` (the folds were always pair-disjoint), kept
for existing scripts."""
