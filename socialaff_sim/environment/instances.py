"""The human instances an environment replays: loaded from a dataset spec, grouped by task.

``data`` is a dataset spec as on the command line (``synthetic``, ``synthetic:SEED``,
``sbu:PATH``, ``npz:DIR``, ...), a :class:`~socialaff_sim.data.dataset.Dataset`, or a
sequence of :class:`~socialaff_sim.data.interaction.Interaction`. For a synthetic spec
only the interactions the environment plays are generated (the generator seeds each
interaction on its own, so they are the same instances as in the full dataset).
Every interaction label must have a task file (``envs/``, found by name or alias).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..data.dataset import Dataset
from ..data.synthetic import INTERACTIONS, SyntheticConfig, generate_dataset
from ..data.interaction import Interaction
from ..data.specs import load_dataset
from ..errors import ConfigError, DataError, choices
from ..sim.tasks import TaskSpec, available_tasks, load_task, task_for_label

__all__ = ["DataSpec", "EpisodePool", "load_pool"]

DataSpec = str | Dataset | Sequence[Interaction]
"""What ``data=`` accepts."""


@dataclass(frozen=True)
class EpisodePool:
    """The instances of an environment, in a stable order, with their tasks."""

    instances: tuple[Interaction, ...]
    """Every instance an episode may replay (cut to ``max_frames`` when set)."""
    labels: tuple[str, ...]
    """The interaction labels, sorted (the observation's one-hot order)."""
    tasks: dict[str, TaskSpec]
    """Task of each label."""

    def indices(self, *, interaction: str | None = None, instance: str | None = None) -> list[int]:
        """Positions of the instances an episode may pick, optionally restricted (reset options)."""
        if instance is not None:
            hits = [i for i, x in enumerate(self.instances) if x.instance_id == instance]
            if not hits:
                some = [x.instance_id for x in self.instances[:6]]
                raise ConfigError(f"reset options: no instance {instance!r} in this environment; ids look like {choices(some)}")
            return hits
        if interaction is not None:
            if interaction not in self.labels:
                raise ConfigError(f"reset options: interaction {interaction!r} is not played here; choose {choices(self.labels)}")
            return [i for i, x in enumerate(self.instances) if x.label == interaction]
        return list(range(len(self.instances)))


def _synthetic(spec: str, labels: tuple[str, ...] | None) -> Dataset:
    _, _, rest = spec.partition(":")
    if rest and not rest.isdigit():
        raise DataError(f"dataset spec {spec!r}: expected 'synthetic' or 'synthetic:SEED' with an integer seed")
    seed = int(rest) if rest else 0
    if labels is None:
        return generate_dataset(seed=seed)
    unknown = [lbl for lbl in labels if lbl not in INTERACTIONS]
    if unknown:
        raise ConfigError(f"interactions: the synthetic dataset has no {choices(unknown)}; it has {choices(INTERACTIONS)}")
    keep = tuple(lbl for lbl in INTERACTIONS if lbl in labels)
    return generate_dataset(seed=seed, config=SyntheticConfig(interactions=keep))


def _task_of(label: str) -> TaskSpec:
    return load_task(label) if label in available_tasks() else task_for_label(label)


def load_pool(data: DataSpec, interactions: str | Sequence[str] | None, max_frames: int | None) -> EpisodePool:
    """The instances of ``data`` whose label is in ``interactions`` (``None``: all labels), with their tasks."""
    labels = (interactions,) if isinstance(interactions, str) else (None if interactions is None else tuple(interactions))
    if labels is not None and not labels:
        raise ConfigError("interactions: expected a label, a list of labels or None (all), found an empty list")
    if isinstance(data, str):
        dataset = _synthetic(data, labels) if data.partition(":")[0] == "synthetic" else load_dataset(data)
        inters = tuple(dataset)
    elif isinstance(data, Dataset):
        inters = tuple(data)
    else:
        inters = tuple(data)
        if not all(isinstance(i, Interaction) for i in inters):
            raise ConfigError("data: expected a dataset spec (e.g. 'synthetic'), a Dataset or a list of Interaction")
    present = sorted({i.label for i in inters})
    if labels is None:
        labels = tuple(present)
    missing = [lbl for lbl in labels if lbl not in present]
    if missing:
        raise ConfigError(f"interactions: the data has no instance of {choices(missing)}; it has {choices(present)}")
    labels = tuple(sorted(set(labels)))
    tasks = {lbl: _task_of(lbl) for lbl in labels}
    chosen = [i for i in inters if i.label in tasks]
    if max_frames is not None:
        chosen = [i.slice(0, max_frames) if i.n_frames > max_frames else i for i in chosen]
    return EpisodePool(tuple(gap_filled(i) for i in chosen), labels, tasks)


def gap_filled(inter: Interaction) -> Interaction:
    """``inter`` with its untracked joints filled in once (:meth:`Interaction.filled_joints`), valid where finite.

    Every reset reads the filled joints several times (scene posing, body measurements, key
    joints); interpolating once here takes that cost out of the episodes. Joints never tracked
    stay NaN and invalid.
    """
    if inter.valid is None or bool(inter.valid.all()):
        return inter
    joints = inter.filled_joints()
    return inter.replace(joints=joints, valid=np.isfinite(joints).all(axis=-1))
