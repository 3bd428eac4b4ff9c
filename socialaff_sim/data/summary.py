"""Per-class summary of a dataset: counts, lengths, frame rates, key-joint availability."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dataset import Dataset
from .skeletons import KEY_JOINTS, N_KEY

__all__ = ["ClassSummary", "summarize", "format_summary"]


@dataclass(frozen=True)
class ClassSummary:
    """Statistics of one interaction class."""

    label: str
    count: int
    frames_min: int
    frames_mean: float
    frames_max: int
    seconds_mean: float
    fps: tuple[float, ...]
    """Distinct frame rates, frames per second."""
    layouts: tuple[str, ...]
    key_available: np.ndarray
    """(2, 5) float: fraction of frames in which each agent's key joint was tracked."""
    has_object: bool
    actor_pairs: int
    subevents: tuple[str, ...]


def summarize(dataset: Dataset) -> list[ClassSummary]:
    """One :class:`ClassSummary` per class, sorted by label."""
    rows = []
    for label in dataset.labels:
        items = dataset.of_label(label).interactions
        frames = np.array([i.n_frames for i in items])
        seconds = np.array([i.duration for i in items])
        valid = np.concatenate([i.key_valid() for i in items], axis=0)  # (sum T, 2, 5)
        subs: list[str] = []
        for i in items:
            subs.extend(n for n in i.subevent_names if n not in subs)
        rows.append(
            ClassSummary(
                label=label,
                count=len(items),
                frames_min=int(frames.min()),
                frames_mean=float(frames.mean()),
                frames_max=int(frames.max()),
                seconds_mean=float(seconds.mean()),
                fps=tuple(sorted({round(i.fps, 3) for i in items})),
                layouts=tuple(sorted({i.layout.name for i in items})),
                key_available=valid.mean(axis=0),
                has_object=any(i.has_object for i in items),
                actor_pairs=len({tuple(sorted(i.actors)) for i in items}),
                subevents=tuple(subs),
            )
        )
    return rows


def _fps_text(fps: tuple[float, ...]) -> str:
    if len(fps) <= 2:
        return "/".join(f"{f:.4g}" for f in fps)
    return f"{min(fps):.1f}-{max(fps):.1f}"


def format_summary(dataset: Dataset) -> str:
    """A plain-text report of :func:`summarize` for the command line."""
    rows = summarize(dataset)
    total = sum(r.count for r in rows)
    lines = [f"dataset {dataset.name!r}: {total} instances in {len(rows)} classes"]
    head = f"{'class':<20}{'n':>4}{'pairs':>6}{'frames min/mean/max':>22}{'mean s':>8}{'fps':>12}  layout"
    lines += ["", head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r.label:<20}{r.count:>4}{r.actor_pairs:>6}"
            f"{f'{r.frames_min}/{r.frames_mean:.0f}/{r.frames_max}':>22}{r.seconds_mean:>8.1f}"
            f"{_fps_text(r.fps):>12}  {','.join(r.layouts)}"
        )
    lines += ["", "key-joint availability (fraction of frames tracked, agent 0 | agent 1; '-' = layout lacks it):"]
    head = f"{'class':<20}" + "".join(f"{k:>13}" for k in KEY_JOINTS) + f"{'object':>8}"
    lines += [head, "-" * len(head)]
    for r in rows:
        cells = []
        for k in range(N_KEY):
            a0, a1 = r.key_available[:, k]
            cells.append("-|-" if a0 == 0 and a1 == 0 else f"{a0:.2f}|{a1:.2f}")
        lines.append(f"{r.label:<20}" + "".join(f"{c:>13}" for c in cells) + f"{'yes' if r.has_object else 'no':>8}")
    subs = [r for r in rows if r.subevents]
    if subs:
        lines += ["", "ground-truth sub-events:"]
        lines += [f"  {r.label}: {' -> '.join(r.subevents)}" for r in subs]
    if dataset.notes:
        lines += ["", "loader notes:"]
        for key, value in dataset.notes.items():
            lines.append(f"  {key}: {value:.4g}" if isinstance(value, float) else f"  {key}: {value}")
    return "\n".join(lines)
