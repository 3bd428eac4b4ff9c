"""Figures of a synthesis: ground-truth vs synthesized key joints over time, inferred sub-events shaded."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from ..data.skeletons import KEY_JOINTS
from ..errors import SocialAffError

__all__ = ["plot_key_joint_tracks"]

_AXES = ("x (toward agent 1)", "y", "z (up)")


def plot_key_joint_tracks(
    path: str | Path,
    fps: float,
    ground_truth: np.ndarray,
    synthesized: np.ndarray,
    subevents: np.ndarray,
    subevent_names: tuple[str, ...],
    *,
    human: np.ndarray | None = None,
    n_observed: int = 0,
    title: str = "",
) -> Path:
    """Write a PNG grid (5 key joints × 3 axes) of agent 1's key joints over time.

    ``ground_truth``, ``synthesized`` and ``human``: (T, 5, 3) metres in the canonical frame;
    ``subevents`` (T,) inferred labels (−1 none), shaded; the observed prefix is hatched grey.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # the plot extra is optional
        raise SocialAffError("plots need matplotlib: pip install 'socialaff-sim[plot]'") from exc
    T = ground_truth.shape[0]
    t = np.arange(T) / fps
    fig, axes = plt.subplots(len(KEY_JOINTS), 3, figsize=(13, 11), sharex=True)
    colours = plt.get_cmap("tab10")
    for k, name in enumerate(KEY_JOINTS):
        for c in range(3):
            ax = axes[k, c]
            if n_observed:
                ax.axvspan(t[0], t[min(n_observed, T) - 1], color="0.85", hatch="//", alpha=0.5, lw=0)
            start = 0
            for i in range(1, T + 1):
                if i == T or subevents[i] != subevents[start]:
                    if subevents[start] >= 0:
                        ax.axvspan(t[start], t[i - 1], color=colours(int(subevents[start]) % 10), alpha=0.15, lw=0)
                    start = i
            if human is not None:
                ax.plot(t, human[:, k, c], color="tab:red", lw=0.8, ls=":", label="human (agent 0)")
            ax.plot(t, ground_truth[:, k, c], color="k", lw=1.2, label="agent 1 ground truth")
            ax.plot(t, synthesized[:, k, c], color="tab:green", lw=1.4, ls="--", label="agent 1 synthesized")
            if k == 0:
                ax.set_title(_AXES[c], fontsize=9)
            if c == 0:
                ax.set_ylabel(f"{name} (m)", fontsize=8)
            ax.tick_params(labelsize=7)
    for c in range(3):
        axes[-1, c].set_xlabel("time (s)", fontsize=8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    from matplotlib.patches import Patch

    used = sorted({int(s) for s in subevents if s >= 0})
    handles += [Patch(color=colours(s % 10), alpha=0.3) for s in used]
    labels += [f"inferred: {subevent_names[s]}" for s in used]
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=80, format="png")
    plt.close(fig)
    return path
