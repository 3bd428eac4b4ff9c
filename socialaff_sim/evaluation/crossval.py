"""Cross-validation tasks: one (interaction class, fold, method) per task.

Each task fits a fresh method on the fold's training instances (folds from
:func:`.splits.make_folds`) and runs it on every test instance under the run's
evaluation protocol (:func:`.streaming.run_protocol`).
Its random generator is derived from the run seed and the task's identity
alone (class name, fold, method name), so results do not depend on the
executor, the number of workers or the order in which tasks run.
"""

from __future__ import annotations

import inspect
import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset
from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, SocialAffError, choices
from .metrics import HORIZONS_S, horizon_key_joint_error, joint_error, key_joint_error, parse_confusion
from ..inference.presets import PRESETS as _PRESETS
from ..inference.protocol import DEFAULT_N_OBSERVED, MethodFactory, Prediction, ReactionMethod
from .splits import SPLITS, make_folds
from .streaming import PAPER_DELTA_T, PROTOCOLS, run_protocol_measured

__all__ = ["EvaluationConfig", "Task", "TaskResult", "InstanceScore", "make_method", "make_tasks", "run_task", "task_seed"]

EXECUTORS = ("process", "ray", "serial")
PRESETS = _PRESETS


@dataclass(frozen=True)
class EvaluationConfig:
    """Settings of Experiment 1."""

    n_folds: int = 4
    """k [—]: cross-validation folds per interaction class."""
    protocol: str = "causal"
    """[—]: What a method sees when it produces agent 1's frames: ``"causal"``, ``"paper"`` or ``"offline"``
    (an upper bound); see :mod:`.streaming`."""
    split: str = "pair"
    """[—]: How the folds hold data apart: ``"pair"``, ``"actor"``, ``"recording"`` or ``"block"``
    (optimistic); see :mod:`.splits`."""
    preset: str = "default"
    """[—]: Configuration preset handed to the method factories that take one: ``"default"`` or ``"paper"``."""
    max_folds: int | None = None
    """[—]: Run only the first this many of the ``n_folds`` folds (each keeps the training set of a k-fold
    split), for time-limited runs; ``None``: all. Tables of such runs say so."""
    max_test: int | None = None
    """[—]: At most this many test instances per fold (the first in the fold's order), for time-limited runs;
    ``None``: all. Tables of such runs say so."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: frames of agent 1 observed before synthesis."""
    seed: int = 0
    """[—]: Run seed: the folds and every task's generator derive from it."""
    replicate: int = 0
    """r [—]: Method replicate: ``0`` gives every task the run seed's own generator; ``r >= 1`` gives every
    task another generator of the same seed while the folds stay the same, so that runs with several ``r``
    measure the spread that a method's own randomness (initialisation, sampling) puts on its errors."""
    executor: str = "process"
    """[—]: Where tasks run: ``"process"`` (local process pool), ``"ray"`` (a Ray cluster) or ``"serial"`` (this process)."""
    workers: int | None = None
    """[—]: Parallel workers (process pool size, or Ray CPUs of a local instance); ``None``: all CPUs."""
    address: str | None = None
    """[—]: Ray cluster address (``executor="ray"``); ``None`` starts a local Ray instance."""
    horizons_s: tuple[float, ...] = HORIZONS_S
    """h [s]: Forecast horizons of the horizon errors (``()``: none); see :mod:`.streaming`."""
    horizon_every_s: float = 0.5
    """S [s]: Spacing of the forecast times (rounded to whole frames, at least one frame)."""

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            raise ConfigError(f"protocol: expected {choices(PROTOCOLS)}, found {self.protocol!r}")
        if self.split not in SPLITS:
            raise ConfigError(f"split: expected {choices(SPLITS)}, found {self.split!r}")
        if self.preset not in PRESETS:
            raise ConfigError(f"preset: expected {choices(PRESETS)}, found {self.preset!r}")
        if self.max_folds is not None and not 1 <= self.max_folds <= self.n_folds:
            raise ConfigError(f"max_folds: expected 1..{self.n_folds} (n_folds), found {self.max_folds}")
        if self.max_test is not None and self.max_test < 1:
            raise ConfigError(f"max_test: expected at least 1, found {self.max_test}")
        if self.executor not in EXECUTORS:
            raise ConfigError(f"executor: expected {choices(EXECUTORS)}, found {self.executor!r}")
        if self.replicate < 0:
            raise ConfigError(f"replicate: expected at least 0, found {self.replicate}")
        if self.n_folds < 2:
            raise ConfigError(f"n_folds: expected at least 2, found {self.n_folds}")
        if self.n_observed < 1:
            raise ConfigError(f"n_observed: expected at least 1, found {self.n_observed}")
        if self.workers is not None and self.workers < 1:
            raise ConfigError(f"workers: expected at least 1, found {self.workers}")
        if any(not (h > 0 and h < 1e3) for h in self.horizons_s) or len(set(self.horizons_s)) != len(self.horizons_s):
            raise ConfigError(f"horizons_s: expected distinct horizons in seconds > 0, found {self.horizons_s}")
        if not self.horizon_every_s > 0:
            raise ConfigError(f"horizon_every_s: expected seconds > 0, found {self.horizon_every_s}")


def _stable(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def task_seed(seed: int, label: str, fold: int, method: str, replicate: int = 0) -> np.random.SeedSequence:
    """The seed sequence of one task, from the run seed, the replicate and the task's identity only."""
    if replicate == 0:  # the stream of every run before replicates existed: their results stay reproducible
        return np.random.SeedSequence(seed, spawn_key=(1, _stable(label), fold, _stable(method)))
    # spawn key 3: apart from the folds' (0, …), replicate 0's (1, …) and the bootstrap's (2, …) streams
    return np.random.SeedSequence(seed, spawn_key=(3, replicate, _stable(label), fold, _stable(method)))


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
    protocol: str = "causal"
    preset: str = "default"
    horizons_s: tuple[float, ...] = ()
    horizon_every_s: float = 0.5
    replicate: int = 0


@dataclass(frozen=True)
class InstanceScore:
    """The errors of one test instance."""

    instance_id: str
    key_joint_error_m: float
    joint_error_m: float
    horizon_errors_m: tuple[float, ...] = ()
    """Key-joint error at each of the task's ``horizons_s`` (metres; NaN where not measurable)."""


@dataclass(frozen=True)
class TaskResult:
    """What a task sends back."""

    label: str
    fold: int
    method: str
    scores: tuple[InstanceScore, ...]
    seconds: float
    """Wall time of fit + the reactor's calls on every test instance (not the horizon forecasts), seconds."""
    confusion: np.ndarray | None = field(default=None)
    """(n_truth, P) pooled sub-event confusion counts, or ``None`` without ground truth or parse."""
    n_labelled: int = 0
    """Test frames with a ground-truth sub-event label."""
    call_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(C,) wall time of every reactor call on the test instances, seconds (the latency figures)."""


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
            folds = make_folds(insts, config.n_folds, config.split, rng=fold_rng(config.seed, label))
        except SocialAffError as exc:
            raise ConfigError(f"interaction {label!r}, --split {config.split}: {exc}") from None
        short = [i.n_frames <= config.n_observed + 1 for i in insts]
        excluded[label] = int(sum(short))
        n_test[label] = 0
        for f, (train, test) in enumerate(folds[: config.max_folds]):
            test_set = tuple(insts[i] for i in test if not short[i])[: config.max_test]
            n_test[label] += len(test_set)
            if not test_set:
                continue
            for name, factory in methods:
                tasks.append(
                    Task(label, f, name, factory, tuple(insts[i] for i in train), test_set, config.n_observed, config.seed,
                         config.protocol, config.preset, tuple(config.horizons_s), config.horizon_every_s,
                         config.replicate)
                )
    return tasks, excluded, n_test


def make_method(factory: MethodFactory, preset: str) -> ReactionMethod:
    """A fresh method from ``factory``, handing it ``preset`` when it takes one."""
    try:
        takes = "preset" in inspect.signature(factory).parameters
    except (TypeError, ValueError):  # a builtin or C callable: no preset keyword
        takes = False
    return factory(preset=preset) if takes else factory()


def run_task(task: Task) -> TaskResult:
    """Fit the method on the training instances and score every test instance."""
    rng = np.random.default_rng(task_seed(task.seed, task.label, task.fold, task.method, task.replicate))
    start = time.perf_counter()
    method = make_method(task.factory, task.preset)
    try:
        method.fit(task.train, rng=rng)
        fit_seconds = time.perf_counter() - start
        runs = []
        for inst in task.test:
            steps = [max(1, round(h * inst.fps)) for h in task.horizons_s]
            runs.append(run_protocol_measured(
                method, inst, protocol=task.protocol, n_observed=task.n_observed, rng=rng, delta_t=PAPER_DELTA_T,
                horizon_frames=max(steps, default=0), horizon_every=max(1, round(task.horizon_every_s * inst.fps)),
            ))
        predictions: list[Prediction] = [r.prediction for r in runs]
        call_seconds = np.concatenate([r.call_seconds for r in runs]) if runs else np.zeros(0)
        seconds = fit_seconds + float(call_seconds.sum())
        scores = tuple(
            InstanceScore(
                inst.instance_id, key_joint_error(r.prediction, inst), joint_error(r.prediction, inst),
                tuple(horizon_key_joint_error(r.forecast_times, r.forecasts, inst, max(1, round(h * inst.fps)))
                      for h in task.horizons_s),
            )
            for r, inst in zip(runs, task.test, strict=True)
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
    return TaskResult(task.label, task.fold, task.method, scores, seconds, confusion, n_labelled, call_seconds)
