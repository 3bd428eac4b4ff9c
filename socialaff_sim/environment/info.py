"""The ``info`` dictionary of the environment's ``reset`` and ``step`` (docs/environment.md, "info").

At every step: ``interaction``, ``instance``, ``frame`` (the frame reached), ``time`` (simulated s since the
reset), ``subevent`` / ``subevent_index`` (the sub-event the reward used), ``subgoals`` (``{name: met so
far}``), ``subgoals_now`` (``{name: contact holds now}``), ``success`` (every sub-goal met, no failure),
``failed``, ``failures`` (``{kind: triggered}``), ``adapter`` (the adapter's kind), ``termination_reason``
(:mod:`~socialaff_sim.environment.episode_end`), ``physics_warnings`` (``{name: count}`` during the step),
``action_adjustment`` ((5,) m, :mod:`~socialaff_sim.environment.actions`), and after a step (not after
``reset``) ``ik_error`` ((5,) m), ``force_on_human`` (N) and the ``reward_<term>`` terms, which sum to the
reward (:mod:`~socialaff_sim.environment.reward`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..data.interaction import Interaction
from ..sim.simulator import Simulator
from .adapters import AdapterFrame

__all__ = ["step_info"]


def step_info(sim: Simulator, inter: Interaction, frame: AdapterFrame, adapter: str, reason: str | None,
              step_warnings: Mapping[str, int], adjustment: np.ndarray,
              terms: Mapping[str, float] | None) -> dict[str, Any]:
    """The ``info`` of a step (``terms``: its reward terms) or of a reset (``terms`` ``None``).

    ``sim``: the episode's simulator after the step; ``inter``: the instance played; ``frame``: the adapter's
    frame the reward was scored on; ``adapter``: its kind; ``reason``: the termination reason or ``None``;
    ``step_warnings``: MuJoCo's warnings during the step; ``adjustment`` (5,) m: the envelope's move of each
    target row (copied).
    """
    scorer = sim.scorer
    subgoals = {r.name: bool(r.success) for r in scorer.subgoals}
    subgoals_now = {r.name: bool(r.current) for r in scorer.subgoals}
    info: dict[str, Any] = {
        "interaction": inter.label,
        "instance": inter.instance_id,
        "frame": int(sim.frame),
        "time": float(sim.time),
        "subevent": frame.subevent_name,
        "subevent_index": int(frame.subevent),
        "subgoals": subgoals,
        "subgoals_now": subgoals_now,
        "success": bool(all(subgoals.values()) and not scorer.failed),
        "failed": bool(scorer.failed),
        "failures": {f.kind: bool(f.triggered) for f in scorer.failures},
        "adapter": adapter,
        "termination_reason": reason,
        "physics_warnings": dict(step_warnings),
        "action_adjustment": adjustment.copy(),
    }
    if terms is not None:  # the IK's error after its latest solve, the force over this step's physics steps
        info["ik_error"] = np.array(sim.ik_errors, dtype=np.float64)
        info["force_on_human"] = float(sim.control_force)
        info.update({f"reward_{k}": float(v) for k, v in terms.items()})
    return info
