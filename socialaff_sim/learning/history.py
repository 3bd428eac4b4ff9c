"""What the Metropolis-Hastings chain did, iteration by iteration (``SocialAffordanceModel.history_``)."""

from __future__ import annotations

import numpy as np

from .mh import MOVES

__all__ = ["new_history", "summary_line", "acceptance_rates"]


def new_history(iterations: int, initial_log_p: float) -> dict[str, np.ndarray]:
    """An empty record of a chain of ``iterations`` outer iterations.

    Keys: ``"log_posterior"`` (I + 1,) float64, log P* of the current state after each iteration (entry 0:
    the start); ``"temperature"`` (I,) float64, T of each iteration; and per dynamics m in
    :data:`~socialaff_sim.learning.mh.MOVES`, ``"proposed_<m>"`` and ``"accepted_<m>"`` (I,) int64, the
    proposals drawn (including those with no admissible choice, which are rejected) and accepted.
    """
    out: dict[str, np.ndarray] = {
        "log_posterior": np.full(iterations + 1, np.nan),
        "temperature": np.ones(iterations),
    }
    out["log_posterior"][0] = initial_log_p
    for m in MOVES:
        out[f"proposed_{m}"] = np.zeros(iterations, np.int64)
        out[f"accepted_{m}"] = np.zeros(iterations, np.int64)
    return out


def acceptance_rates(history: dict[str, np.ndarray]) -> dict[str, tuple[int, int, float]]:
    """Per dynamics drawn at least once: (proposed, accepted, accepted / proposed) over the whole chain."""
    out = {}
    for m in MOVES:
        n, a = int(history[f"proposed_{m}"].sum()), int(history[f"accepted_{m}"].sum())
        if n:
            out[m] = (n, a, a / n)
    return out


def summary_line(history: dict[str, np.ndarray]) -> str:
    """One line: accepted / proposed per dynamics and log P* at the start and the end of the chain."""
    rates = acceptance_rates(history)
    moves = ", ".join(f"{m} {a}/{n} ({r:.1%})" for m, (n, a, r) in rates.items()) or "no proposals"
    lp = history["log_posterior"]
    return f"MH moves accepted: {moves}; log P* {lp[0]:.1f} -> {lp[-1]:.1f}"
