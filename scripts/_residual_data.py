"""Training and held-out instances of ``scripts/train_residual.py`` (recorded or synthetic), and its model fits.

Each dataset spec (``handover:PATH``, ``sbu:PATH``, ``nuisi:PATH``, ``npz:DIR``, ...) is loaded, its
instances of the requested labels kept, and every (dataset, label) class is split on its own with
:func:`socialaff_sim.evaluation.splits.make_folds`: ``folds`` folds under the dataset's split (``pair``
unless the split table names another for that dataset kind), fold ``held_out_fold`` held out, the others
trained on. The fold dealing is seeded per class from the run's seed and the label, so a run's split is a
function of (specs, labels, splits, folds, held-out fold, seed) alone.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.specs import load_dataset
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.data.synthetic.config import SyntheticConfig
from socialaff_sim.errors import ConfigError, choices
from socialaff_sim.evaluation.splits import SPLITS, make_folds
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.learning.config import LearningConfig

DEFAULT_SPLITS: tuple[str, ...] = ("pair", "nuisi=block")
"""``--split`` default: pair-disjoint everywhere, block for NuiSI (each class is one recording of one pair, so
no pair can be held out; the project's accuracy evaluation splits NuiSI so too)."""


@dataclass(frozen=True)
class HeldOutSplit:
    """Which instances of one (dataset, label) class are trained on and which are held out."""

    spec: str
    """The dataset spec the class was loaded from."""
    label: str
    """The interaction label."""
    split: str
    """The split's name (:data:`socialaff_sim.evaluation.splits.SPLITS`)."""
    train_ids: tuple[str, ...]
    """Instance ids trained on (model fit and RL episodes)."""
    held_out_ids: tuple[str, ...]
    """Instance ids held out (evaluation only)."""


def parse_splits(items: Sequence[str]) -> dict[str, str]:
    """``["pair", "nuisi=block"]`` → ``{"": "pair", "nuisi": "block"}``: a bare name is the split of every
    dataset kind not named otherwise (key ``""``)."""
    out: dict[str, str] = {}
    for item in items:
        kind, eq, name = item.rpartition("=")
        if name not in SPLITS or (eq and not kind):
            raise ConfigError(f"--split: expected NAME or KIND=NAME with NAME in {choices(SPLITS)}, found {item!r}")
        out[kind] = name
    return out


def split_for(spec: str, splits: Mapping[str, str]) -> str:
    """The split of dataset ``spec`` (its kind is the part before the first ``:``)."""
    kind = spec.partition(":")[0]
    if kind in splits:
        return splits[kind]
    if "" in splits:
        return splits[""]
    raise ConfigError(f"--split: no split given for dataset kind {kind!r} and no default; add NAME or {kind}=NAME")


def real_split(specs: Sequence[str], labels: Sequence[str], splits: Mapping[str, str], folds: int,
               held_out_fold: int, seed: int) -> tuple[list[Interaction], list[Interaction], list[HeldOutSplit]]:
    """(training instances, held-out instances, the split of each class) of the recorded ``specs``.

    A label may occur in several datasets (each its own class, split on its own); every label must occur in
    at least one, and every instance's label must be one of ``labels`` to be kept."""
    if not 0 <= held_out_fold < folds:
        raise ConfigError(f"--held-out-fold: expected 0 … {folds - 1}, found {held_out_fold}")
    train: list[Interaction] = []
    held: list[Interaction] = []
    table: list[HeldOutSplit] = []
    for spec in specs:
        insts = list(load_dataset(spec))
        for label in sorted({i.label for i in insts} & set(labels)):
            cls = [i for i in insts if i.label == label]
            name = split_for(spec, splits)
            rng = np.random.default_rng([seed, zlib.crc32(label.encode())])
            tr_idx, te_idx = make_folds(cls, folds, name, rng=rng)[held_out_fold]
            train += [cls[k] for k in tr_idx]
            held += [cls[k] for k in te_idx]
            table.append(HeldOutSplit(spec, label, name, tuple(cls[k].instance_id for k in tr_idx),
                                      tuple(cls[k].instance_id for k in te_idx)))
    missing = sorted(set(labels) - {t.label for t in table})
    if missing:
        raise ConfigError(f"--interactions: no instance of {choices(missing)} in --data {choices(list(specs))}")
    ids = [i.instance_id for i in train + held]
    if len(set(ids)) != len(ids):
        raise ConfigError("--data: two instances share an id; the episodes are addressed by id (one dataset twice?)")
    return train, held, table


# -- the run's instances and models (``s``: a ``train_residual.Settings``) -----------------------------------------------------
def build_data(s: Any) -> tuple[list[Interaction], list[Interaction]]:
    """(training instances, held-out instances): with ``s.data``, the recorded classes split as
    :func:`real_split` splits them; otherwise two synthetic datasets, seeds ``s.seed`` and
    ``s.seed + 1``."""
    if s.data:
        train_r, held_r, _ = real_split(s.data, s.labels, parse_splits(s.split), s.folds, s.held_out_fold, s.seed)
        return train_r, held_r
    train = generate_dataset(s.seed, SyntheticConfig(interactions=s.labels, instances_per_interaction=s.train_instances))
    held = generate_dataset(s.seed + 1, SyntheticConfig(interactions=s.labels, instances_per_interaction=s.eval_instances))
    return list(train.interactions), list(held.interactions)


def fit_models(s: Any, train: Sequence[Interaction]) -> dict[str, SocialAffordanceModel]:
    """One affordance model per interaction, fitted on the training instances (seeded per label)."""
    models = {}
    for label in s.labels:
        rng = np.random.default_rng([s.seed, zlib.crc32(label.encode())])
        learning = LearningConfig(iterations=s.fit_iterations)
        models[label] = SocialAffordanceModel(learning=learning).fit([i for i in train if i.label == label], rng=rng)
    return models


def describe_split(s: Any, train: Sequence[Interaction], held: Sequence[Interaction]) -> dict[str, Any]:
    """What was trained on and what was held out: instance ids per label."""
    def ids(insts: Sequence[Interaction]) -> dict[str, list[str]]:
        return {lbl: [i.instance_id for i in insts if i.label == lbl] for lbl in sorted({i.label for i in insts})}
    if s.data:
        what = (f"recorded: {', '.join(s.data)}; split {' '.join(s.split)}, fold {s.held_out_fold} of {s.folds} "
                f"held out per (dataset, label), seed {s.seed}")
    else:
        what = (f"synthetic dataset seed {s.seed + 1}, {s.eval_instances} instances per interaction "
                f"(training: seed {s.seed}, {s.train_instances} per interaction)")
    return {"held_out": what, "train_ids": ids(train), "held_out_ids": ids(held)}
