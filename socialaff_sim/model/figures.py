"""Text and figure summaries of a learned model (sub-events, durations, joint groupings).

matplotlib (the optional ``plot`` extra) is imported inside :func:`draw_groupings`, so that the
rest of the package works without it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import atomic_path

__all__ = ["format_model", "draw_groupings"]

_BONES = [(0, 1), (0, 2), (0, 3), (0, 4)]  # base to each wrist and ankle, per agent


def format_model(model) -> str:  # noqa: ANN001 - SocialAffordanceModel
    """A text table: sub-events with mean durations and each joint's group (Null / id / absent)."""
    names = model.joint_names_
    width = max(len(n) for n in names)
    lines = [f"model of {model.label_!r}: |S| = {model.n_subevents_}, trained on {len(model.parses_)} instances"]
    dur = model.mean_durations_
    header = " " * (width + 2) + "".join(f"{n[:12]:>13s}" for n in model.subevent_names_)
    lines.append("")
    lines.append(" " * (width + 2) + "".join(f"{f'{d:.2f} s':>13s}" for d in dur))
    lines.append(header)
    for j, name in enumerate(names):
        cells = []
        for s in range(model.n_subevents_):
            z = model.grouping_[s, j]
            cells.append("-" if not model.available_[j] else ("Null" if z == 0 else f"group {z}"))
        lines.append(f"{name:<{width}s}  " + "".join(f"{c:>13s}" for c in cells))
    lines.append("")
    lines.append("start p(s1): " + ", ".join(f"{p:.2f}" for p in model.start_probs_))
    return "\n".join(lines)


def draw_groupings(model, path: str | Path) -> Path:  # noqa: ANN001 - SocialAffordanceModel
    """Side view (canonical x–z) of each sub-event's mean end configuration, joints coloured by group."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    S = model.n_subevents_
    fig, axes = plt.subplots(1, S, figsize=(3.2 * S, 3.6), squeeze=False)
    pts = model.mean_end_[:, model.available_]
    pts = pts[np.isfinite(pts).all(axis=-1)]
    lo = pts.min(axis=0) - 0.15 if pts.size else np.zeros(3)
    hi = pts.max(axis=0) + 0.15 if pts.size else np.ones(3)
    palette = plt.get_cmap("tab10")
    for s, ax in enumerate(axes[0]):
        x = model.mean_end_[s]
        z = model.grouping_[s]
        for a in (0, 1):
            for p, c in _BONES:
                i, k = 5 * a + p, 5 * a + c
                if np.isfinite(x[[i, k]]).all():
                    ax.plot(x[[i, k], 0], x[[i, k], 2], color="0.75", lw=2, zorder=1)
        for j in range(len(z)):
            if not model.available_[j] or not np.isfinite(x[j]).all():
                continue
            colour = "0.55" if z[j] == 0 else palette((z[j] - 1) % 10)
            marker = "o" if j < 10 else "*"
            ax.scatter(x[j, 0], x[j, 2], s=90 if j < 10 else 180, color=colour, marker=marker,
                       edgecolor="k", linewidth=0.5, zorder=2)
        ax.set_title(f"{model.subevent_names_[s]} ({model.mean_durations_[s]:.2f} s)", fontsize=10)
        ax.set_xlabel("x (m, toward agent 1)")
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(min(lo[2], 0.0), hi[2])
        ax.set_aspect("equal", adjustable="box")
    axes[0][0].set_ylabel("z (m)")
    fig.suptitle(f"{model.label_}: joint groups at each sub-event's end (grey = Null)", fontsize=11)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path, suffix=path.suffix) as tmp:
        fig.savefig(tmp, dpi=110, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
