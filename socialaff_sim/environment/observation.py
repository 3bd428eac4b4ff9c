"""The environment's observation: a :class:`gymnasium.spaces.Dict` of bounded float32 boxes.

All positions are in the robot frame (fixed at reset: origin on the floor under
the robot's base, x toward the person, z up), metres, clipped to ±P
(``EnvConfig.position_bound``). With t the current frame and H the history:

==================== =============== =======================================================
key                  shape           content
==================== =============== =======================================================
``human_keys``       (H, 5, 3)       the person's (agent 0's) key joints at frames t+2−H … t+1
                                     (clamped to the instance), oldest first: the last row is
                                     the frame the next action is for; 0 where the layout lacks a joint
``human_mask``       (5,)            1 for the key joints the recording's layout provides
``object``           (H, 3)          the simulated object's centre at frames t+1−H … t (0 without one)
``object_present``   (1,)            1 when the instance has a simulated object
``robot_keys``       (5, 3)          the robot's five key frames in physics now
``joint_pos``        (n,)            the robot's hinge angles, rad, clipped to ±π
``joint_vel``        (n,)            their velocities, rad/s, clipped to ±V
``proposal``         (5, 3)          the adapter's proposal for the next frame (the base of a
                                     ``residual`` action); rows it lacks hold the robot's key frame
``subevent_belief``  (S,)            the adapter's sub-event belief (zero-padded to the largest |S|)
``interaction``      (C,)            one-hot of the episode's interaction among the env's C
``subgoal_progress`` (G,)            per sub-goal of the env's tasks: qualifying contact time over
                                     its ``min_duration`` (1 once met), 0 for other tasks' sub-goals
``subgoal_achieved`` (G,)            1 for each sub-goal met so far in the episode (latched)
``subgoal_current``  (G,)            1 for each sub-goal whose contact holds now (not latched)
``progress``         (1,)            (t + φ) / (T − 1), the fraction of the person's track played
                                     (φ: the share of frame t → t+1 already simulated, with a
                                     control period; 0 at frame boundaries)
==================== =============== =======================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from ..data.skeletons import N_KEY

__all__ = ["ObservationLayout", "OBSERVATION_KEYS"]

OBSERVATION_KEYS = (
    "human_keys", "human_mask", "object", "object_present", "robot_keys", "joint_pos", "joint_vel",
    "proposal", "subevent_belief", "interaction", "subgoal_progress", "subgoal_achieved", "subgoal_current", "progress",
)


def _box(lo: float, hi: float, shape: tuple[int, ...]) -> spaces.Box:
    return spaces.Box(low=np.float32(lo), high=np.float32(hi), shape=shape, dtype=np.float32)


@dataclass(frozen=True)
class ObservationLayout:
    """Sizes and bounds of the observation; :meth:`build` makes one observation."""

    history: int
    """H, frames of history."""
    n_joints: int
    """n, the robot's hinges."""
    n_subevents: int
    """S, length of the belief vector."""
    interactions: tuple[str, ...]
    """The env's C interaction labels (one-hot order)."""
    subgoals: tuple[str, ...]
    """The env's G sub-goal names (union over its tasks)."""
    position_bound: float
    """P, metres."""
    velocity_bound: float
    """V, rad/s."""

    def space(self) -> spaces.Dict:
        H, P = self.history, self.position_bound
        return spaces.Dict({
            "human_keys": _box(-P, P, (H, N_KEY, 3)),
            "human_mask": _box(0.0, 1.0, (N_KEY,)),
            "object": _box(-P, P, (H, 3)),
            "object_present": _box(0.0, 1.0, (1,)),
            "robot_keys": _box(-P, P, (N_KEY, 3)),
            "joint_pos": _box(-np.pi, np.pi, (self.n_joints,)),
            "joint_vel": _box(-self.velocity_bound, self.velocity_bound, (self.n_joints,)),
            "proposal": _box(-P, P, (N_KEY, 3)),
            "subevent_belief": _box(0.0, 1.0, (self.n_subevents,)),
            "interaction": _box(0.0, 1.0, (len(self.interactions),)),
            "subgoal_progress": _box(0.0, 1.0, (len(self.subgoals),)),
            "subgoal_achieved": _box(0.0, 1.0, (len(self.subgoals),)),
            "subgoal_current": _box(0.0, 1.0, (len(self.subgoals),)),
            "progress": _box(0.0, 1.0, (1,)),
        })

    def build(
        self,
        *,
        human_track: np.ndarray,
        human_mask: np.ndarray,
        object_history: np.ndarray,
        object_present: bool,
        robot_keys: np.ndarray,
        joint_pos: np.ndarray,
        joint_vel: np.ndarray,
        proposal: np.ndarray,
        belief: np.ndarray,
        interaction: str,
        subgoal_progress: dict[str, float],
        subgoal_achieved: dict[str, bool],
        subgoal_current: dict[str, bool],
        frame: int,
        n_frames: int,
        phase: float = 0.0,
    ) -> dict[str, np.ndarray]:
        """One observation at frame ``frame`` (and ``phase`` ∈ [0, 1) of the way to the next: the share of the
        frame's physics steps already run, 0 between frames); every array is freshly allocated.

        ``human_track`` (T, 5, 3) robot frame (finite); ``object_history`` (H, 3) robot frame,
        oldest first; ``belief`` (S',) with S' ≤ S; the sub-goal mappings are keyed by sub-goal name
        (names of other tasks are absent and read 0).
        """
        P, V = self.position_bound, self.velocity_bound
        T = human_track.shape[0]
        rows = np.clip(np.arange(frame + 2 - self.history, frame + 2), 0, T - 1)

        def pos(a: np.ndarray) -> np.ndarray:  # np.clip's value, without its dispatch (called a dozen times a step)
            return np.minimum(np.maximum(a, -P), P).astype(np.float32)

        b = np.zeros(self.n_subevents, dtype=np.float32)
        b[: len(belief)] = np.minimum(np.maximum(belief, 0.0), 1.0)
        onehot = np.zeros(len(self.interactions), dtype=np.float32)
        onehot[self.interactions.index(interaction)] = 1.0
        prog = np.array([min(max(subgoal_progress.get(n, 0.0), 0.0), 1.0) for n in self.subgoals], dtype=np.float32)

        def flags(state: dict[str, bool]) -> np.ndarray:
            return np.array([1.0 if state.get(n, False) else 0.0 for n in self.subgoals], dtype=np.float32)
        return {
            "human_keys": pos(human_track[rows]),
            "human_mask": np.asarray(human_mask, dtype=np.float32).copy(),
            "object": pos(object_history),
            "object_present": np.array([1.0 if object_present else 0.0], dtype=np.float32),
            "robot_keys": pos(robot_keys),
            "joint_pos": np.minimum(np.maximum(joint_pos, -np.pi), np.pi).astype(np.float32),
            "joint_vel": np.minimum(np.maximum(joint_vel, -V), V).astype(np.float32),
            "proposal": pos(proposal),
            "subevent_belief": b,
            "interaction": onehot,
            "subgoal_progress": prog,
            "subgoal_achieved": flags(subgoal_achieved),
            "subgoal_current": flags(subgoal_current),
            "progress": np.array([min(1.0, (frame + phase) / max(1, n_frames - 1))], dtype=np.float32),
        }
