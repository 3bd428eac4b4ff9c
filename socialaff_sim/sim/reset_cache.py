"""What a :class:`~socialaff_sim.sim.simulator.Simulator` remembers between resets, so that a reset replays arrays.

Everything a reset derives from an instance alone (the world offset, the human's per-frame capsule
poses and sizes, the reach segments, the robot frame and the scaler's placement, the carry plan,
the physics sub-steps per frame, the robot's home pose in the world) is a pure function of the
instance and of ``placement_frames``; a :class:`Placement` holds it, computed on the instance's
first reset. The settle IK at frame 0 (``SimConfig.settle_iterations`` solves, the bulk of a cold
reset) is a pure function of that and of the first frame's targets; :class:`Settled` holds its
result together with the IK state it leaves behind (the configuration and the collision limit's
per-pair memory), so a later reset with the same targets restores that state instead of solving
again. Nothing here changes what a reset produces: tests/test_env_speed.py checks that a reused
simulator and a fresh one give bitwise the same episodes.

The cache is bounded (least recently used entries are dropped), keyed by the instance *object*
(identity: the cache keeps a reference, so an id is never reused while cached) and
``placement_frames``.
"""

from __future__ import annotations

import copy
from collections import OrderedDict
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..data.interaction import Interaction
from ..errors import SimulationError
from ..retarget.collision import PairMemory
from ..retarget.measure import BodyMeasurements
from ..retarget.scaling import KeyJointScaler, RobotFrame, ScalingConfig
from .carry import CarryPlan, plan_carry
from .human import HumanPose, pose_human, world_offset
from .reach import human_segments
from .scene import Scene
from .tasks import ObjectTask

__all__ = ["Placement", "Settled", "ResetCache", "build_placement"]

MAX_PLACEMENTS = 256
"""Most instances a simulator remembers (least recently reset ones are dropped first)."""
MAX_SETTLED = 8
"""Most distinct first-frame targets remembered per instance (a stochastic proposal gives new ones)."""


@dataclass(frozen=True)
class Settled:
    """The settle IK's outcome for one set of first-frame targets."""

    qpos: np.ndarray
    """(nq_ik,) the settled configuration, world frame."""
    limit: PairMemory
    """The IK collision limit's memory after the last settle solve."""


@dataclass
class Placement:
    """What a reset derives from one instance (see the module docstring); read-only once built."""

    interaction: Interaction
    placement_frames: int | None
    offset: np.ndarray
    """(3,) metres: data frame → simulator world."""
    pose: HumanPose
    segments: tuple[np.ndarray, np.ndarray, np.ndarray]
    """The human's reach segments (:func:`~socialaff_sim.sim.reach.human_segments`)."""
    scaler: KeyJointScaler
    """The scaler right after its reset (copied at every episode start: its online placement moves)."""
    frame: RobotFrame
    carry: CarryPlan | None
    obj_track: np.ndarray | None
    n_sub: int
    """Physics steps per data frame."""
    timestep: float
    """The physics timestep that fits ``n_sub`` steps in a frame, s."""
    home: np.ndarray
    """(nq_ik,) the robot's home posture placed in the world (the IK's start)."""
    settled: OrderedDict[bytes, Settled] = field(default_factory=OrderedDict)

    def settled_for(self, targets: np.ndarray) -> Settled | None:
        """The remembered settle for world-frame ``targets`` (5, 3), if any (bitwise-equal targets only)."""
        return self.settled.get(np.ascontiguousarray(targets, dtype=np.float64).tobytes())

    def remember(self, targets: np.ndarray, settled: Settled) -> None:
        """Remember ``settled`` for ``targets``, dropping the oldest beyond :data:`MAX_SETTLED`."""
        self.settled[np.ascontiguousarray(targets, dtype=np.float64).tobytes()] = settled
        while len(self.settled) > MAX_SETTLED:
            self.settled.popitem(last=False)


class ResetCache:
    """Placements by instance (identity) and ``placement_frames``, least recently used dropped first."""

    def __init__(self, capacity: int = MAX_PLACEMENTS) -> None:
        self.capacity = int(capacity)
        self._entries: OrderedDict[tuple[int, int | None], Placement] = OrderedDict()
        self.misses = 0
        """Placements computed so far (cold resets)."""

    def get(self, interaction: Interaction, placement_frames: int | None) -> Placement | None:
        key = (id(interaction), placement_frames)
        hit = self._entries.get(key)
        if hit is None or hit.interaction is not interaction:
            return None
        self._entries.move_to_end(key)
        return hit

    def put(self, placement: Placement) -> None:
        self.misses += 1
        self._entries[(id(placement.interaction), placement.placement_frames)] = placement
        while len(self._entries) > self.capacity:
            self._entries.popitem(last=False)

    def __len__(self) -> int:
        return len(self._entries)


def build_placement(inter: Interaction, placement_frames: int | None, scene: Scene, ik_home: np.ndarray,
                    measurements: BodyMeasurements, scaling: ScalingConfig, timestep: float,
                    task_object: ObjectTask | None) -> Placement:
    """What a reset derives from ``inter`` alone, computed afresh.

    ``placement_frames``: place and scale the robot from agent 1's first that many frames only (``None``: the
    whole recording); ``scene``: the physics scene of the instance's layout; ``ik_home`` (nq_ik,): the robot's
    home posture in the robot frame; ``measurements``: the robot's; ``timestep``: the wanted physics step, s
    (shortened so that a data frame holds a whole number of steps); ``task_object``: the task's object, if any.
    """
    placed = inter if placement_frames is None else agent1_prefix(inter, placement_frames)
    offset = world_offset(placed)
    pose = pose_human(scene.body, inter, offset)
    scaler = KeyJointScaler(measurements, scaling)
    frame = scaler.reset(placed, offset)
    carry = None
    if task_object is not None and inter.object is not None:
        carry = plan_carry(inter, offset, task_object, scene.body.hand_joints)
    n_sub = max(1, int(round(1.0 / (inter.fps * timestep))))
    home = np.asarray(ik_home, dtype=np.float64).copy()
    home[:3] = frame.to_world(home[:3])
    turn = np.array([np.cos(frame.yaw / 2), 0.0, 0.0, np.sin(frame.yaw / 2)])
    quat = np.empty(4)
    mujoco.mju_mulQuat(quat, turn, home[3:7])
    home[3:7] = quat
    return Placement(
        interaction=inter, placement_frames=placement_frames, offset=offset, pose=pose,
        segments=human_segments(pose, scene.body.radii), scaler=copy.copy(scaler), frame=frame, carry=carry,
        obj_track=None if inter.object is None else inter.object + offset, n_sub=n_sub,
        timestep=1.0 / (inter.fps * n_sub), home=home,
    )


def agent1_prefix(inter: Interaction, n: int) -> Interaction:
    """The instance with agent 1 after frame ``n`` marked invalid (its filled joints hold frame n − 1)."""
    if not 1 <= n <= inter.n_frames:
        raise SimulationError(f"placement_frames: expected 1..{inter.n_frames} for this instance, found {n}")
    return inter.hide_agent_after(1, n)
