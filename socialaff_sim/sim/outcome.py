"""One outcome code per episode, in the manner of HandoverSim's: success, or the first reason it was not one.

=================== =============================================================================================
code                when
=================== =============================================================================================
``success``         every sub-goal met, no failure condition triggered and the robot never fell
``fell``            the robot fell (:class:`~socialaff_sim.sim.fall.FallWatch`: base below half its height at home
                    or trunk past 60°) before any failure triggered
``self_collision``, the task file's failure of that kind triggered first (``contact_force`` is "excessive force":
``contact_force``,  the smoothed normal force on the person above its threshold; ``object_dropped``: the object
``object_dropped``  touched the floor after the person let go)
``no_contact``      nothing above; the first unmet sub-goal (in the task file's order) never touched: its robot
                    group never touched its person group (or the object) at any physics step
``contact_lost``    nothing above; the first unmet sub-goal touched at some step but not at the last one
``timeout``         nothing above; the first unmet sub-goal still touches at the episode's last step: the
                    recording ended before the sub-goal was met (too short a hold, a hold begun too late, a
                    touch only below a high five's height condition)
=================== =============================================================================================

A fall and a failure both end an episode's chances; whichever came first (by simulated time) is the code, a fall
before a failure at the same time. A touch counts at any height and in any sub-event here (the sub-goal's own
conditions decide whether it is *met*; this decides only which code an unmet one gets).
"""

from __future__ import annotations

from collections.abc import Sequence

from .scoring import FailureResult, SubgoalResult

__all__ = ["OUTCOMES", "episode_outcome"]

OUTCOMES = ("success", "fell", "self_collision", "contact_force", "object_dropped", "no_contact", "contact_lost",
            "timeout")
"""Every outcome code :func:`episode_outcome` returns."""


def episode_outcome(subgoals: Sequence[SubgoalResult], failures: Sequence[FailureResult], fall_time: float | None,
                    end_time: float) -> tuple[str, float | None]:
    """(code, time): the episode's outcome (one of :data:`OUTCOMES`, by the rules of the module docstring) and the
    simulated time (s) it refers to: the fall's or the failure's first time; for ``success`` the time the last
    sub-goal was met; ``contact_lost`` the last touch; ``timeout`` ``end_time``; ``no_contact`` ``None``.

    ``subgoals`` and ``failures``: the scorer's results at the episode's end (after
    :meth:`~socialaff_sim.sim.scoring.SubgoalScorer.finish`), in the task file's order; ``fall_time``: the
    first fallen frame's time (``None``: never fell); ``end_time``: the episode's last simulated time (s).
    """
    # Events that end an episode's chances, earliest first; a fall ranks before a failure at the same time.
    events = [(fall_time, 0, "fell")] if fall_time is not None else []
    events += [(f.time if f.time is not None else end_time, 1 + i, f.kind)
               for i, f in enumerate(failures) if f.triggered]
    if events:
        t, _, code = min(events)
        return code, float(t)
    unmet = [s for s in subgoals if not s.success]
    if not unmet:
        times = [s.time for s in subgoals if s.time is not None]
        return "success", (max(times) if times else None)
    first = unmet[0]
    if first.first_touch is None:
        return "no_contact", None
    if first.current or first.low:
        return "timeout", float(end_time)
    return "contact_lost", first.last_touch
