"""The held-out evaluation of ``scripts/train_residual.py``: every policy judged on the same (instance, reset seed)
pairs, and the paired summaries.

Arms: the trained residual (deterministic; through the gate and bias when the run has them), the zero residual
(the affordance model alone: the zero action of the plain residual environment, never through a gate or a bias),
optionally a constant action on the plain environment (``--eval-constant``), and, for a gated run, the start: the
zero action through the gate, i.e. the bias on the acting labels and nothing elsewhere. Summaries:
``summary`` trained − zero (the declared one), ``summary_constant`` constant − zero, ``summary_start``
start − zero, ``summary_learned`` trained − start (what training added to its starting point).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from _residual_episodes import Policy, run_episodes, zero_policy
from _residual_stats import summarize

__all__ = ["evaluate_held_out"]


def evaluate_held_out(plain: gym.Env, gated: gym.Env | None, episodes: Sequence[tuple[str, int]],
                      trained: Policy | None, seed: int, constant: Sequence[float] = ()) -> dict[str, Any]:
    """Play the arms of the module docstring on ``episodes``; ``gated``: the gated environment (``None``: the
    run has no gate; the trained policy plays ``plain``). ``trained`` ``None``: the model selection kept the
    start, and the "residual" arm is the start's rows (the zero output through the gate; without a gate, the
    zero residual's). Returns the summaries and the per-episode rows."""
    rows_zero = run_episodes(plain, episodes, zero_policy(plain))
    rows_start = None if gated is None else run_episodes(gated, episodes, zero_policy(gated))
    if trained is not None:
        rows_res = run_episodes(plain if gated is None else gated, episodes, trained)
    else:
        rows_res = [dict(r) for r in (rows_zero if rows_start is None else rows_start)]
    out: dict[str, Any] = {"summary": summarize(rows_res, rows_zero, seed),
                           "episodes": {"residual": rows_res, "zero_residual": rows_zero}}
    if constant:
        action = np.asarray(constant, np.float32)
        rows_const = run_episodes(plain, episodes, lambda obs: action.copy())
        out |= {"summary_constant": summarize(rows_const, rows_zero, seed), "episodes_constant": rows_const}
    if rows_start is not None:
        out |= {"summary_start": summarize(rows_start, rows_zero, seed),
                "summary_learned": summarize(rows_res, rows_start, seed), "episodes_start": rows_start}
    return out
