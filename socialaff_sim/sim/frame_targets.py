"""One frame's robot-frame targets from agent 1's key joints, within an episode of a
:class:`~socialaff_sim.sim.simulator.Simulator`.

A source (the recording, the model's synthesis, a policy) gives agent 1's five key joints in the data
frame; :class:`FrameTargets` turns them into the five targets the IK follows (robot frame, metres): scaled
onto the robot and placed by the episode's :class:`~socialaff_sim.retarget.scaling.KeyJointScaler`, and,
with ``SimConfig.contact_completion``, the wrists completed onto a contact the task wants
(:mod:`~socialaff_sim.retarget.contact_completion`, reading the scene through
:class:`~socialaff_sim.sim.contact_targets.ContactAnchors`), the robot moved in toward such a contact when it
is beyond reach. The simulator owns one, resets it with each instance's placement and calls it from
:meth:`~socialaff_sim.sim.simulator.Simulator.retarget`.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import SimulationError
from ..retarget.contact_completion import ContactCompletion, ContactCompletionConfig
from ..retarget.flight_target import FlightState, ballistic, landing_time
from ..retarget.ik import RobotIK
from ..retarget.scaling import KeyJointScaler, object_anchors
from .contact_targets import ContactAnchors, object_in_flight, offered_hand
from .human import HumanPose
from .reset_cache import Placement
from .scene import Scene
from .tasks import TaskSpec

__all__ = ["FrameTargets", "fill_targets"]


def fill_targets(targets: np.ndarray, home: np.ndarray) -> np.ndarray:
    """(5, 3) robot-frame ``targets`` (metres) with their NaN rows filled: a missing base at its ``home`` (5, 3)
    key frame, a missing limb at its home offset from the base."""
    if targets.shape != (5, 3):
        raise SimulationError(f"targets: expected shape (5, 3) (robot frame, metres), found {targets.shape}")
    out = targets.copy()
    if not np.isfinite(out[0]).all():
        out[0] = home[0]
    bad = ~np.isfinite(out).all(axis=1)
    out[bad] = out[0] + (home[bad] - home[0])
    return out


class FrameTargets:
    """Agent 1's key joints → the robot-frame targets of a frame (see the module docstring).

    ``completion``: the contact completion's settings (``None``: scaling alone); ``lookahead`` (s): how far
    ahead the object's recorded track is extrapolated for the scaler (``ScalingConfig.object_lookahead``).
    """

    def __init__(self, task: TaskSpec, completion: ContactCompletionConfig | None, lookahead: float) -> None:
        self.task = task
        self.lookahead = float(lookahead)
        self.completion = None if completion is None else ContactCompletion(completion)
        self._anchors: dict[str, ContactAnchors] = {}
        self._completed_frame = -1

    def reset(self, place: Placement, scaler: KeyJointScaler, scene: Scene, ik: RobotIK, arm: float) -> None:
        """Start an episode on ``place``'s instance with the episode's ``scaler`` (moved by the online placement),
        the physics ``scene`` of its layout, the ``ik`` whose latest solution is the robot's commanded pose and the
        robot's arm length ``arm`` (m)."""
        self.place, self.scaler, self.scene, self.ik, self.arm = place, scaler, scene, ik, float(arm)
        self.interaction = place.interaction
        if self.completion is not None:
            self.completion.reset()
            self._completed_frame = -1
            name = place.interaction.layout.name
            if name not in self._anchors:
                self._anchors[name] = ContactAnchors(scene, self.task)

    def object_anchors(self, frame: int) -> np.ndarray | None:
        """(K, 3) world frame: the recorded object at ``frame`` and its path over the next ``lookahead`` s
        (:func:`~socialaff_sim.retarget.scaling.object_anchors`); ``None`` without an object track."""
        if self.place.obj_track is None:
            return None
        return object_anchors(self.place.obj_track, frame, self.interaction.fps, self.lookahead)

    def weight_at(self, t: int) -> np.ndarray | None:
        """(2,) the completion's blend weights if the latest call completed frame ``t``, else ``None``."""
        if self.completion is None or self._completed_frame != t:
            return None
        return self.completion.weight.copy()

    def touches_met(self, subgoals: dict[str, bool] | None) -> bool:
        """Whether the task's touches are all met by ``subgoals`` (each sub-goal's success so far; ``None``: none
        yet): its contact sub-goals with the person met by a touch (``min_duration`` shorter than one data frame: a
        high five's or a fist bump's, not a handshake's or a grip's); ``False`` in a task with none."""
        dt = 1.0 / self.interaction.fps
        touches = [sg.name for sg in self.task.subgoals if sg.kind == "contact" and sg.min_duration < dt]
        return bool(touches) and subgoals is not None and all(subgoals.get(n, False) for n in touches)

    def __call__(self, keys: np.ndarray, t: int, pose: HumanPose, now: int, data: mujoco.MjData, released: bool,
                 subevent: str | None, contact: bool, contact_inside: bool, contact_inside_next: bool,
                 subgoals: dict[str, bool] | None = None) -> np.ndarray:
        """(5, 3) robot-frame targets for frame ``t`` from agent 1's ``keys`` (5, 3) in the data frame, the person
        posed by ``pose``, the simulator at frame ``now`` with physics ``data``, the carried object ``released``
        or not, each sub-goal's success so far ``subgoals`` (the last frame's; ``None``: no frame yet); the flags as
        in :meth:`~socialaff_sim.sim.simulator.Simulator.retarget`."""
        place = self.place
        world_keys = np.asarray(keys, dtype=np.float64) + place.offset
        if self.completion is None:
            return self.scaler(world_keys, pose.joints[t], self.object_anchors(t))
        cc = self.completion.config
        fps = self.interaction.fps
        B = self.scene.n_bones
        obj, moving = None, False
        carry = place.carry
        if carry is not None:
            moving = released or t >= carry.release_frame
            obj = object_in_flight(data, self.scene, (t - now) / fps) if moving else carry.track[t]
        anchors = self._anchors[self.interaction.layout.name]
        hands = pose.pos[t, B:B + 2]
        # Of the person's hands, the model's intent is taken to be for the one held out farther.
        offered = offered_hand(self.interaction.key_joints()[t, 0])
        if contact_inside_next and cc.approach and not self.completion.weight.any():
            self._approach(anchors, data, world_keys, hands, obj, subevent, pose.joints[t], offered)
        catch = cc.catch_flight and obj is not None and anchors.catch_window(data, subevent, moving)
        flight = anchors.flight(data, (t - now) / fps) if catch else None
        if catch and cc.catch_approach:
            self._approach_flight(flight, float(anchors.radius[2]), data, world_keys, pose.joints[t])  # type: ignore[arg-type]
        out = self.scaler(world_keys, pose.joints[t], self.object_anchors(t))
        world = place.frame.to_world(out)
        x = anchors.gather(data, world[1:3], self.ik.frame_positions()[1:3], hands, obj, self.arm, subevent,
                           intent=contact, offered=offered, free=moving, inside=contact_inside,
                           catch=catch, flight=flight, met=cc.release_met and self.touches_met(subgoals))
        world[1:3] = self.completion(x, t, 1.0 / fps)
        self._completed_frame = t
        return place.frame.to_robot(world)

    def _approach_flight(self, flight: FlightState, radius: float, data: mujoco.MjData, keys: np.ndarray,
                         partner: np.ndarray) -> None:
        """Move the robot in toward a ball whose predicted ``flight`` (object ``radius``) passes beyond the arm's
        reach from both its physical shoulders (``ContactCompletionConfig.catch_approach``; world-frame ``keys``
        of agent 1 and ``partner`` joints of the frame): toward the path's point that needs the least moving in
        (:meth:`~socialaff_sim.retarget.scaling.KeyJointScaler.approach_nearest`)."""
        cc = self.completion.config  # type: ignore[union-attr]
        times = np.linspace(flight.lead, max(flight.lead, min(flight.lead + cc.flight_horizon,
                                                              landing_time(flight, radius))), 64)
        path, _ = ballistic(flight.position, flight.velocity, times, flight.gravity)
        shoulders = data.xpos[self.scene.limb_body_ids[:2]]
        d = np.linalg.norm(path[None] - shoulders[:, None, :], axis=-1)  # (2, K)
        if d.min() <= cc.reach * self.arm:
            return  # the ball passes within reach of a hand already
        self.scaler.approach_nearest(path[::4], keys, partner, flight=True)

    def _approach(self, anchors: ContactAnchors, data: mujoco.MjData, keys: np.ndarray, hands: np.ndarray,
                  obj: np.ndarray | None, subevent: str | None, partner: np.ndarray, offered: int) -> None:
        """Move the robot in toward the contact the model means to make (world-frame ``keys`` of agent 1, the
        person's ``hands`` (2, 3), joints ``partner`` (J, 3) and the object ``obj`` of the frame): of the pairs
        the task wants, the model's wrist and the anchor nearest each other, the person's ``offered`` hand (the
        one held out farther from their body) the only one of theirs (:meth:`KeyJointScaler.approach`)."""
        centre, allowed = anchors.wanted(data, hands, obj, subevent, offered)
        allowed[:, 2:] = False  # a person's hand, not an object: a ball in flight is met where the model meets it
        cc = self.completion.config  # type: ignore[union-attr]
        d = np.linalg.norm(keys[1:3, None, :] - centre[None], axis=-1)
        d = np.where(allowed & np.isfinite(d), d, np.inf)
        if not np.isfinite(d).any():
            return
        side, a = np.unravel_index(int(np.argmin(d)), d.shape)
        shoulders = data.xpos[self.scene.limb_body_ids[:2]]
        if np.linalg.norm(centre[a] - shoulders, axis=1).min() <= cc.reach * self.arm + cc.reach_band:
            return  # within reach of a hand already: where the model puts the robot stands
        self.scaler.approach(centre[a], np.array([side]), keys, partner)
