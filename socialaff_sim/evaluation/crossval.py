"""Actor-disjoint cross-validation tasks: one (interaction class, fold, method) per task.

Each task fits a fresh method on the fold's training instances and predicts
every test instance from its observed part (:func:`.protocol.observed_part`).
Its random generator is derived from the run seed and the task's identity
alone (class name, fold, method name), so results do not depend on the
executor, the number of workers or the order in which tasks run.
"""

from __future__ import annotations

import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset, actor_disjoint_folds
from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, SocialAffError, choices
from .metrics import joint_error, key_joint_error, parse_confusion
from ..inference.protocol import DEFAULT_N_OBSERVED, MethodFactory, Prediction, observed_part

__all__ = ["EvaluationConfig", "Task", "TaskResult", "InstanceScore", "make_tasks", "run_task", "task_seed"]

EXECUTORS = ("process", "ray", "serial")


@dataclass(frozen=True)
class EvaluationConfig:
    """Settings of Experiment 1."""

    n_folds: int = 4
    """k [—]: actor-disjoint cross-validation folds per interaction class."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: frames of agent 1 observed before synthesis."""
    seed: int = 0
    """[—]: Run seed: the folds and every task's generator derive from it."""
    executor: str = "process"
    """[—]: Where tasks run: ``"process"`` (local process pool), ``"ray"`` (a Ray cluster) or ``"serial"`` (this process)."""
    workers: int | None = None
    """[—]: Parallel workers (process pool size, or Ray CPUs of a local instance); ``None``: all CPUs."""
    address: str | None = None
    """[—]: Ray cluster address (``executor="ray"``); ``None`` starts a local Ray instance."""

    def __post_init__(self) -> None:
        if self.executor not in EXECUTORS:
            raise ConfigError(f"executor: expected {choices(EXECUTORS)}, found {self.executor!r}")
        if self.n_folds < 2:
            raise ConfigError(f"n_folds: expected at least 2, found {self.n_folds}")
        if self.n_observed < 1:
            raise ConfigError(f"n_observed: expected at least 1, found {self.n_observed}")
        if self.workers is not None and self.workers < 1:
            raise ConfigError(f"workers: expected at least 1, found {self.workers}")


def _stable(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def task_seed(seed: int, label: str, fold: int, method: str) -> np.random.SeedSequence:
    """The seed sequence of one task, from the run seed and the task's identity only."""
    return np.random.SeedSequence(seed, spawn_key=(1, _stable(label), fold, _stable(method)))


def fold_rng(seed: int, label: str) -> np.random.Generator:
    """The generator that splits one interaction class into folds."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0, _stable(label))))


@dataclass(frozen=True)
class Task:
    """One unit of work; picklable (it carries the method's factory and the data)."""

    label: str
    fold: int
    method: str
    factory: MethodFactory
    train: tuple[Interaction, ...]
    test: tuple[Interaction, ...]
    n_observed: int
    seed: int


@dataclass(frozen=True)
class InstanceScore:
    """The errors of one test instance."""

    instance_id: str
    key_joint_error_m: float
    joint_error_m: float


@dataclass(frozen=True)
class TaskResult:
    """What a task sends back."""

    label: str
    fold: int
    method: str
    scores: tuple[InstanceScore, ...]
    seconds: float
    """Wall time of fit + all predictions, seconds."""
    confusion: np.ndarray | None = field(default=None)
    """(n_truth, P) pooled sub-event confusion counts, or ``None`` without ground truth or parse."""
    n_labelled: int = 0
    """Test frames with a ground-truth sub-event label."""


def make_tasks(
    dataset: Dataset,
    methods: Sequence[tuple[str, MethodFactory]],
    labels: Sequence[str],
    config: EvaluationConfig,
) -> tuple[list[Task], dict[str, int], dict[str, int]]:
    """The tasks of a run, plus per class the number of excluded (too short) and of test instances."""
    tasks: list[Task] = []
    excluded: dict[str, int] = {}
    n_test: dict[str, int] = {}
    for label in labels:
        insts = dataset.of_label(label).interactions
        try:
            folds = actor_disjoint_folds(insts, config.n_folds, rng=fold_rng(config.seed, label))
        except SocialAffError as exc:
            raise ConfigError(f"interaction {label!r}: {exc}") from None
        short = [i.n_frames <= config.n_observed + 1 for i in insts]
        excluded[label] = int(sum(short))
        n_test[label] = 0
        for f, (train, test) in enumerate(folds):
            test_set = tuple(insts[i] for i in test if not short[i])
            n_test[label] += len(test_set)
            if not test_set:
                continue
            for name, factory in methods:
                tasks.append(
                    Task(label, f, name, factory, tuple(insts[i] for i in train), test_set, config.n_observed, config.seed)
                )
    return tasks, excluded, n_test


def run_task(task: Task) -> TaskResult:
    """Fit the method on the training instances and score every test instance."""
    rng = np.random.default_rng(task_seed(task.seed, task.label, task.fold, task.method))
    start = time.perf_counter()
    method = task.factory()
    try:
        method.fit(task.train, rng=rng)
        predictions: list[Prediction] = []
        for inst in task.test:
            pred = method.predict(observed_part(inst, task.n_observed), n_observed=task.n_observed, rng=rng)
            if not isinstance(pred, Prediction) or pred.n_frames != inst.n_frames or pred.n_observed != task.n_observed:
                raise ModelError(
                    f"expected a Prediction of {inst.n_frames} frames with n_observed = {task.n_observed}, "
                    f"found {type(pred).__name__}"
                )
            predictions.append(pred)
        seconds = time.perf_counter() - start
        scores = tuple(
            InstanceScore(inst.instance_id, key_joint_error(p, inst), joint_error(p, inst))
            for p, inst in zip(predictions, task.test, strict=True)
        )
    except SocialAffError as exc:
        raise ModelError(f"method {task.method!r} on {task.label!r}, fold {task.fold}: {exc}") from exc
    confusion, n_labelled = None, 0
    parts = [
        (p.subevents, inst.subevents, len(inst.subevent_names))
        for p, inst in zip(predictions, task.test, strict=True)
        if p.subevents is not None and inst.subevents is not None
    ]
    if parts:
        mats = [parse_confusion(p, g, n) for p, g, n in parts]
        shape = (max(m.shape[0] for m in mats), max(m.shape[1] for m in mats))
        confusion = np.zeros(shape, dtype=np.int64)
        for m in mats:
            confusion[: m.shape[0], : m.shape[1]] += m
        n_labelled = int(sum((g >= 0).sum() for _, g, _ in parts))
    return TaskResult(task.label, task.fold, task.method, scores, seconds, confusion, n_labelled)
