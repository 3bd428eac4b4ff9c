"""What an observer reads from the physics loop: the person's and the robot's key frames, the object, the joints.

:class:`SimulatorViews` is the read-only half of :class:`~.simulator.Simulator` (which inherits it): accessors for
the environment's observations and the demo's figures, none of which changes the episode. They read the state the
simulator keeps (its stage, the episode's robot frame, the person's key joints) and convert between the world and
the robot's frame (:class:`~socialaff_sim.retarget.scaling.RobotFrame`: the robot's placement, heading first).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..data.interaction import Interaction
from ..errors import SimulationError
from ..retarget.scaling import RobotFrame
from .carry import CarryPlan
from .scene import Scene
from .scoring import SubgoalScorer
from .stage import Stage, key_frames
from .support import SupportMeter

__all__ = ["SimulatorViews"]


class SimulatorViews:
    """Read-only accessors of a simulator's current episode (a mixin of :class:`~.simulator.Simulator`)."""

    _stage: Stage | None
    interaction: Interaction | None
    frame: int
    frame_R: RobotFrame
    carry: CarryPlan | None
    _person_keys: np.ndarray
    _home_keys: np.ndarray
    _q: np.ndarray

    def _require(self) -> None:
        if self._stage is None or self.interaction is None:
            raise SimulationError("call Simulator.reset(interaction) first")

    @property
    def scene(self) -> Scene:
        self._require()
        return self._stage.scene  # type: ignore[union-attr]

    @property
    def data(self) -> mujoco.MjData:
        self._require()
        return self._stage.data  # type: ignore[union-attr]

    @property
    def support(self) -> SupportMeter:
        """The outside-support and effort meter of the current scene."""
        self._require()
        return self._stage.stepper.support  # type: ignore[union-attr]

    @property
    def scorer(self) -> SubgoalScorer:
        self._require()
        return self._stage.scorer  # type: ignore[union-attr]

    def _person_xy(self, frame: int) -> np.ndarray:
        """(2,) the mean of agent 0's present key joints at ``frame``, horizontal, world, metres."""
        return np.nanmean(self._person_keys[frame, :, :2], axis=0)

    def human_key_joints(self, frame: int | None = None) -> np.ndarray:
        """(5, 3) agent 0's key joints at ``frame`` (default: the current one), robot frame, metres (NaN if absent)."""
        self._require()
        t = self.frame if frame is None else frame
        return self.frame_R.to_robot(self._person_keys[t])

    def object_position(self) -> np.ndarray | None:
        """(3,) the simulated object's centre, robot frame, metres; ``None`` without an object track."""
        self._require()
        if self.carry is None:
            return None
        return self.frame_R.to_robot(self.data.xpos[self.scene.object_body])

    def robot_key_frames(self) -> np.ndarray:
        """(5, 3) the robot's key frames in physics, robot frame, metres."""
        return self.frame_R.to_robot(key_frames(self.scene, self.data))

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Hinge angles (rad) and velocities (rad/s) of the robot, (n_joints,) each, in robot joint order."""
        sc, d = self.scene, self.data
        return d.qpos[sc.robot_qadr[7:]].copy(), d.qvel[sc.robot_vadr[6:]].copy()

    @property
    def home_key_frames(self) -> np.ndarray:
        """(5, 3) the robot's key frames at its home posture, robot frame, metres (after the first reset)."""
        self._require()
        return self._home_keys.copy()

    @property
    def ik_qpos(self) -> np.ndarray:
        """(nq_ik,) the latest IK solution (free joint then the IK's hinges), world frame."""
        return self._q.copy()
