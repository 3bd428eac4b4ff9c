"""Exclusive wall time per stage of the environment's step, for scripts/bench_env.py.

:class:`StageTimer` wraps callables of the library in place (and puts them back) so that each charges its own
time to a stage and subtracts it from the stage of the wrapped caller it runs in; :func:`instrument` wraps the
environment's stages (:data:`STAGES`). Only scripts/bench_env.py imports this module.
"""

from __future__ import annotations

import functools
import time
from typing import Any

import mujoco

from socialaff_sim.environment import adapters, env as env_module, model_adapter, reward
from socialaff_sim.retarget import ik as ik_module
from socialaff_sim.sim import scoring, simulator, substeps, support

__all__ = ["STAGES", "StageTimer", "instrument"]


class StageTimer:
    """Exclusive wall time per stage: wrapped callables charge their own time to their stage and
    subtract it from the stage of the wrapped caller they run in."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._stack: list[float] = []
        self._undo: list[tuple[Any, str, Any]] = []

    def wrap(self, owner: Any, name: str, stage: str) -> None:
        original = getattr(owner, name, None)
        if original is None:  # an attribute another version of the code renamed: not timed
            return
        timer = self

        @functools.wraps(original)
        def timed(*args: Any, **kwargs: Any) -> Any:
            t = time.perf_counter()
            timer._stack.append(0.0)
            try:
                return original(*args, **kwargs)
            finally:
                dt = time.perf_counter() - t
                inner = timer._stack.pop()
                timer.seconds[stage] = timer.seconds.get(stage, 0.0) + dt - inner
                timer.calls[stage] = timer.calls.get(stage, 0) + 1
                if timer._stack:
                    timer._stack[-1] += dt

        self._undo.append((owner, name, original))
        setattr(owner, name, timed)

    def restore(self) -> None:
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)
        self._undo.clear()


STAGES = ("synthesis", "retargeting", "IK", "physics: mj_step", "physics: sub-step loop", "scoring",
          "observation", "reset", "other")


def instrument(timer: StageTimer) -> None:
    """Wrap the environment's stages (the env's own step, reset, observation and info; the adapters, retargeting,
    IK, physics and scoring of the library) with ``timer``; ``timer.restore()`` undoes it."""
    E = env_module.SocialAffordanceEnv
    timer.wrap(E, "step", "other")
    timer.wrap(E, "reset", "reset")
    for cls in (adapters.GroundTruthAdapter, model_adapter.ModelAdapter):
        timer.wrap(cls, "observe", "synthesis")
        timer.wrap(cls, "log_likelihood", "scoring")
    timer.wrap(simulator.Simulator, "retarget", "retargeting")
    timer.wrap(simulator.Simulator, "step", "other")
    timer.wrap(simulator.Simulator, "solve", "other")
    timer.wrap(simulator.Simulator, "advance", "other")
    timer.wrap(ik_module.RobotIK, "solve", "IK")
    timer.wrap(substeps.FrameStepper, "run", "physics: sub-step loop")
    for name in ("plan", "replan", "advance"):
        timer.wrap(substeps.FrameStepper, name, "physics: sub-step loop")
    timer.wrap(mujoco, "mj_step", "physics: mj_step")
    timer.wrap(scoring.SubgoalScorer, "update", "scoring")
    timer.wrap(scoring.SubgoalScorer, "measure_gaps", "scoring")
    timer.wrap(support.SupportMeter, "update", "scoring")
    timer.wrap(support.SupportMeter, "end_frame", "scoring")
    timer.wrap(reward.RewardTracker, "step", "scoring")
    timer.wrap(E, "_observation", "observation")
    timer.wrap(E, "_info", "observation")
