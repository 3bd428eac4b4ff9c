"""The learning curve of ``scripts/train_residual.py``: a Stable-Baselines3 callback that records every finished
training episode (and stops training once a wall-clock budget is spent, after a whole rollout), and the plot of
those episodes' success and return against the zero-residual reference."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402

__all__ = ["CurveRecorder", "plot_curve"]


class CurveRecorder(BaseCallback):
    """Records every finished training episode: (timesteps so far, interaction, return, success)."""

    def __init__(self, log: Callable[[str], None] | None = None, every: int = 10_000,
                 budget_s: float | None = None) -> None:
        super().__init__()
        self.rows: list[dict[str, Any]] = []
        self._log, self._every, self._next = log, every, every
        self._t0 = time.perf_counter()
        self._budget_s = budget_s
        self.stopped = False
        self.updated_timesteps = 0
        """Environment steps of the rollouts the policy has been updated on (or will be, for the last one)."""

    def _on_rollout_end(self) -> None:
        # The rollout just collected is trained on; once the budget is spent, the next rollout's first step
        # stops learn() before any update, so the policy is exactly that of --timesteps updated_timesteps.
        self.updated_timesteps = int(self.num_timesteps)
        if self._budget_s is not None and time.perf_counter() - self._t0 > self._budget_s:
            self.stopped = True
            self.training_env.training = False  # type: ignore[attr-defined]  # the stop step leaves the statistics alone

    def _on_step(self) -> bool:
        if self.stopped:
            return False
        for done, info in zip(self.locals["dones"], self.locals["infos"]):
            if done:
                self.rows.append({"timesteps": int(self.num_timesteps), "interaction": info["interaction"],
                                  "return": float(info["episode"]["r"]), "success": bool(info["success"])})
        if self._log is not None and self.num_timesteps >= self._next:
            self._next += self._every
            last = self.rows[-100:]
            self._log(f"  {self.num_timesteps} steps, {time.perf_counter() - self._t0:.0f} s; last {len(last)} episodes: "
                      f"success {np.mean([r['success'] for r in last]):.2f}, return {np.mean([r['return'] for r in last]):.1f}")
        return True


def plot_curve(rows: Sequence[Mapping[str, Any]], reference: Mapping[str, Mapping[str, float]], path: Path,
               window: int = 50, start: Mapping[str, Mapping[str, float]] | None = None,
               selection: Mapping[str, Any] | None = None) -> None:
    """Training episodes' success and return (moving average over ``window`` episodes of each interaction)
    against timesteps, with the zero-residual policy on the training instances as dashed reference lines and,
    given ``start`` (a gated run's zero action through its gate and bias, same instances), dotted ones for the
    labels the residual acts on (``rows`` has episodes of them). ``selection`` (``results["selection"]``): the
    checkpoints' deterministic success and return on the selection episodes as black points, the start's as a
    black line, the chosen checkpoint ringed."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    colors = dict(zip(sorted(reference), ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")))
    for label, color in colors.items():
        mine = [r for r in rows if r["interaction"] == label]
        x = np.array([r["timesteps"] for r in mine], float)
        for ax, key in zip(axes, ("success", "return")):
            y = np.array([float(r[key]) for r in mine])
            if y.size:
                w = min(window, y.size)
                ax.plot(x[w - 1:], np.convolve(y, np.ones(w) / w, mode="valid"), color=color,
                        label=f"{label}: residual PPO (training episodes, stochastic)")
            ax.axhline(reference[label][key], color=color, ls="--", lw=1,
                       label=f"{label}: affordance model alone (training instances)")
            if start is not None and mine:
                ax.axhline(start[label][key], color=color, ls=":", lw=1.5,
                           label=f"{label}: the start, bias alone, deterministic (training instances)")
    if selection is not None:
        cps = selection["checkpoints"]
        for ax, key, div in ((axes[0], "successes", "episodes"), (axes[1], "mean_return", None)):
            y0 = selection["start"][key] / (selection["start"][div] if div else 1)
            ax.axhline(y0, color="k", lw=0.8, label="selection: the start, deterministic (selection episodes)")
            x = [c["timesteps"] for c in cps]
            y = [c[key] / (c[div] if div else 1) for c in cps]
            ax.plot(x, y, "ko-", ms=4, lw=0.8, label="selection: checkpoint, deterministic (selection episodes)")
            if selection["chosen"] is not None:
                ax.plot([x[selection["chosen"]]], [y[selection["chosen"]]], "o", ms=11, mfc="none", mec="red",
                        mew=1.5, label="selection: chosen checkpoint")
    axes[0].set(xlabel="environment steps", ylabel=f"success rate (moving mean of {window} episodes)", ylim=(-0.02, 1.02))
    axes[1].set(xlabel="environment steps", ylabel=f"episode return (moving mean of {window} episodes)")
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, fontsize=8, loc="outside lower center", ncol=2)
    fig.suptitle("Residual PPO on the affordance model: learning curve")
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
