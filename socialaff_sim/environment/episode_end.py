"""Why an episode ended, and MuJoCo's own warnings about the physics, per step.

``info["termination_reason"]`` is one of :data:`TERMINATION_REASONS` on the step that ends an
episode and ``None`` on every other step (and after ``reset``):

==================== ============ ============================================================
reason               flag         when
==================== ============ ============================================================
``task_complete``    terminated   the person's track reached its last frame with every sub-goal
                                  met and no failure
``instance_end``     terminated   the track reached its last frame with a sub-goal unmet
``self_collision``,  terminated   the task file's failure of that kind triggered (only with
``contact_force``,                ``terminate_on_failure``; the first in the task file's order
``object_dropped``                when several trigger on one step)
``fell``             terminated   the robot fell: its base below ``EnvConfig.fall_height`` of its
                                  height at home, or its trunk tilted past ``fall_tilt``
``physics_unstable`` truncated    MuJoCo reported a diverging or invalid state (``bad_qacc``,
                                  ``bad_qpos`` or ``bad_qvel`` below; MuJoCo then resets the state,
                                  so the episode cannot go on) or a non-finite robot state
==================== ============ ============================================================

On several at once the order of precedence is ``physics_unstable``, ``fell``, a failure, then
the end of the track. A :class:`gymnasium.wrappers.TimeLimit` truncation (the registered
``max_episode_steps``) is the wrapper's: the environment cannot see it, so the reason stays
``None`` there and ``truncated`` alone says it.

MuJoCo counts its warnings in ``MjData.warning`` (cleared by every reset of the data);
:class:`WarningMonitor` reads the counters after each step and reports the increase per
warning under :data:`WARNING_NAMES`. :class:`EpisodeEnd` makes the decision above, step by step.
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from ..sim.fall import body_up, tilt_angle, tilt_cosine
from ..sim.simulator import Simulator

__all__ = ["TERMINATION_REASONS", "FAILURE_REASONS", "WARNING_NAMES", "UNSTABLE_WARNINGS", "WarningMonitor",
           "EpisodeEnd", "body_up", "tilt_cosine", "tilt_angle"]

FAILURE_REASONS = ("self_collision", "contact_force", "object_dropped")
"""The task files' failure kinds (docs/task_format.md), each a termination reason of its own."""
TERMINATION_REASONS = ("task_complete", "instance_end", *FAILURE_REASONS, "fell", "physics_unstable")
"""Every value ``info["termination_reason"]`` takes besides ``None``."""

WARNING_NAMES: dict[str, mujoco.mjtWarning] = {
    "inertia": mujoco.mjtWarning.mjWARN_INERTIA,
    "contact_full": mujoco.mjtWarning.mjWARN_CONTACTFULL,
    "constraint_full": mujoco.mjtWarning.mjWARN_CNSTRFULL,
    "bad_qpos": mujoco.mjtWarning.mjWARN_BADQPOS,
    "bad_qvel": mujoco.mjtWarning.mjWARN_BADQVEL,
    "bad_qacc": mujoco.mjtWarning.mjWARN_BADQACC,
    "bad_ctrl": mujoco.mjtWarning.mjWARN_BADCTRL,
}
"""Our name of each MuJoCo warning (``info["physics_warnings"]`` keys) and its ``mjtWarning``."""
UNSTABLE_WARNINGS = ("bad_qpos", "bad_qvel", "bad_qacc")
"""Warnings after which MuJoCo has reset the state: the episode ends as ``physics_unstable``."""


class WarningMonitor:
    """Per-step increases of MuJoCo's warning counters on one ``MjData`` at a time."""

    def __init__(self) -> None:
        self._index = [int(w) for w in WARNING_NAMES.values()]
        self._last = [0] * len(WARNING_NAMES)
        self._view: tuple[mujoco.MjData, np.ndarray] | None = None  # a data and its counters' view (read every step)
        self._quiet = dict.fromkeys(WARNING_NAMES, 0)
        self.totals = dict.fromkeys(WARNING_NAMES, 0)
        """Warnings counted since the monitor was made, by name (over every episode)."""

    def _counts(self, data: mujoco.MjData) -> list[int]:
        """Our counters of ``data``, in :data:`WARNING_NAMES` order (Python ints: compared every step)."""
        if self._view is not None and self._view[0] is data:
            number = self._view[1]
        else:
            number = getattr(data.warning, "number", None)  # MuJoCo's bindings: a view of every counter
            if number is None:
                return [int(data.warning[i].number) for i in self._index]
            self._view = (data, number)  # the view stays valid for the data's life (the data is held here)
        every = number.tolist()
        return [every[i] for i in self._index]

    def reset(self, data: mujoco.MjData) -> None:
        """Start from ``data``'s counters now (call after the data was reset, e.g. at an episode's start)."""
        self._last = self._counts(data)

    def step(self, data: mujoco.MjData) -> dict[str, int]:
        """{name: warnings since the last call}; a counter that went down (MuJoCo reset the data) counts from 0."""
        now = self._counts(data)
        if now == self._last:  # the usual case: nothing new
            return dict(self._quiet)
        new = [n - last if n >= last else n for n, last in zip(now, self._last, strict=True)]
        self._last = now
        out = dict(zip(WARNING_NAMES, new, strict=True))
        for name, n in out.items():
            self.totals[name] += n
        return out


class EpisodeEnd:
    """Why an episode ends after a step, in the order of precedence of the module docstring.

    ``fall_height`` [—], ``fall_tilt`` [deg], ``terminate_on_failure``: the fields of
    :class:`~socialaff_sim.environment.config.EnvConfig`. Call :meth:`reset` at every episode's start (the fall
    thresholds are the robot's and the scene's), then :meth:`reason` after every step.
    """

    def __init__(self, fall_height: float, fall_tilt: float, terminate_on_failure: bool) -> None:
        self.fall_height, self.fall_tilt, self.terminate_on_failure = fall_height, fall_tilt, terminate_on_failure
        self._fall: tuple[float, float, np.ndarray] = (0.0, 1.0, np.array([0.0, 0.0, 1.0]))
        self._quat: slice | np.ndarray = slice(3, 7)

    def reset(self, sim: Simulator) -> None:
        """Set the fall thresholds of ``sim``'s robot and scene (after ``sim.reset``)."""
        # Base height (m) below which the robot has fallen, the cosine of the tilt, the body's own up axis.
        self._fall = (self.fall_height * float(sim.home_key_frames[0, 2]),
                      float(np.cos(np.deg2rad(self.fall_tilt))), body_up(sim.scene.home_qpos[3:7]))
        quat = np.asarray(sim.scene.robot_qadr[3:7], dtype=np.int64)  # the root's orientation in qpos
        consecutive = bool(np.array_equal(quat, np.arange(quat[0], quat[0] + 4)))
        self._quat = slice(int(quat[0]), int(quat[0]) + 4) if consecutive else quat  # a view, not a gather, when it can

    def reason(self, sim: Simulator, step_warnings: Mapping[str, int], robot_keys: np.ndarray) -> str | None:
        """Why the episode ends after this step (one of :data:`TERMINATION_REASONS`), or ``None``.

        ``step_warnings``: the step's :meth:`WarningMonitor.step`; ``robot_keys`` (5, 3): the robot's key
        frames now, robot frame (m).
        """
        data = sim.data
        finite = np.logical_and.reduce  # ndarray.all's reduction without its wrappers (every control step)
        if any(step_warnings[k] for k in UNSTABLE_WARNINGS) or not (
                finite(np.isfinite(data.qpos)) and finite(np.isfinite(data.qvel))):
            return "physics_unstable"
        low, cos_tilt, up = self._fall
        if robot_keys[0, 2] < low or tilt_cosine(data.qpos[self._quat], up) < cos_tilt:
            return "fell"
        scorer = sim.scorer
        if self.terminate_on_failure and scorer.failed:
            return next(f.kind for f in scorer.failures if f.triggered)
        if sim.done:
            met = all(r.success for r in scorer.subgoals) and not scorer.failed
            return "task_complete" if met else "instance_end"
        return None
