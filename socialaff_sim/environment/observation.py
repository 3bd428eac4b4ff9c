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
``residual_offset``  (5, 3)          only with ``EnvConfig.residual_tau``: the filtered residual
                                     offset sent on the latest step, metres, robot frame, in [−ρ, ρ]
                                     (the filter's state; 0 at reset)
==================== =============== =======================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from ..data.skeletons import N_KEY

__all__ = ["ObservationLayout", "OBSERVATION_KEYS", "FRAME_KEYS"]

OBSERVATION_KEYS = (
    "human_keys", "human_mask", "object", "object_present", "robot_keys", "joint_pos", "joint_vel",
    "proposal", "subevent_belief", "interaction", "subgoal_progress", "subgoal_achieved", "subgoal_current", "progress",
)
FRAME_KEYS = ("human_keys", "human_mask", "object", "object_present", "proposal", "subevent_belief", "interaction")
"""The keys whose entries change only from one data frame to the next (shared by a frame's control steps)."""


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
    residual_bound: float | None = None
    """ρ, metres: when set, the observation has a ``residual_offset`` entry bounded by it (a filtered residual's
    state); ``None``: no such entry."""

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
            **({} if self.residual_bound is None else
               {"residual_offset": _box(-self.residual_bound, self.residual_bound, (N_KEY, 3))}),
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
        (names of other tasks are absent and read 0). The same as :meth:`assemble` of :meth:`frame_entries`
        and :meth:`step_entries`.
        """
        return self.assemble(
            self.frame_entries(human_track=human_track, human_mask=human_mask, object_history=object_history,
                               object_present=object_present, proposal=proposal, belief=belief,
                               interaction=interaction, frame=frame),
            self.step_entries(robot_keys=robot_keys, joint_pos=joint_pos, joint_vel=joint_vel,
                              subgoal_progress=subgoal_progress, subgoal_achieved=subgoal_achieved,
                              subgoal_current=subgoal_current, frame=frame, n_frames=n_frames, phase=phase))

    def frame_entries(self, *, human_track: np.ndarray, human_mask: np.ndarray, object_history: np.ndarray,
                      object_present: bool, proposal: np.ndarray, belief: np.ndarray, interaction: str,
                      frame: int) -> dict[str, np.ndarray]:
        """The entries of :data:`FRAME_KEYS`: what changes only from one data frame to the next (arguments as in
        :meth:`build`), so that the control steps of a frame can share them (through :meth:`assemble`)."""
        P = self.position_bound
        T = human_track.shape[0]
        rows = np.clip(np.arange(frame + 2 - self.history, frame + 2), 0, T - 1)
        b = np.zeros(self.n_subevents, dtype=np.float32)
        b[: len(belief)] = np.minimum(np.maximum(belief, 0.0), 1.0)
        onehot = np.zeros(len(self.interactions), dtype=np.float32)
        onehot[self.interactions.index(interaction)] = 1.0
        return {
            "human_keys": _clip32(human_track[rows], P),
            "human_mask": np.asarray(human_mask, dtype=np.float32).copy(),
            "object": _clip32(object_history, P),
            "object_present": np.array([1.0 if object_present else 0.0], dtype=np.float32),
            "proposal": _clip32(proposal, P),
            "subevent_belief": b,
            "interaction": onehot,
        }

    def step_entries(self, *, robot_keys: np.ndarray, joint_pos: np.ndarray, joint_vel: np.ndarray,
                     subgoal_progress: dict[str, float], subgoal_achieved: dict[str, bool],
                     subgoal_current: dict[str, bool], frame: int, n_frames: int,
                     phase: float = 0.0, residual_offset: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The entries that change every step (arguments as in :meth:`build`; ``residual_offset`` (5, 3) m, read
        only when the layout has that entry)."""
        prog = np.array([min(max(subgoal_progress.get(n, 0.0), 0.0), 1.0) for n in self.subgoals], dtype=np.float32)

        def flags(state: dict[str, bool]) -> np.ndarray:
            return np.array([1.0 if state.get(n, False) else 0.0 for n in self.subgoals], dtype=np.float32)
        extra = {}
        if self.residual_bound is not None:
            extra["residual_offset"] = _clip32(np.zeros((N_KEY, 3)) if residual_offset is None else residual_offset,
                                               self.residual_bound)
        return {
            **extra,
            "robot_keys": _clip32(robot_keys, self.position_bound),
            "joint_pos": _clip32(joint_pos, np.pi),
            "joint_vel": _clip32(joint_vel, self.velocity_bound),
            "subgoal_progress": prog,
            "subgoal_achieved": flags(subgoal_achieved),
            "subgoal_current": flags(subgoal_current),
            "progress": np.array([min(1.0, (frame + phase) / max(1, n_frames - 1))], dtype=np.float32),
        }

    @staticmethod
    def assemble(frame_part: dict[str, np.ndarray], step_part: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """One observation (keys in :data:`OBSERVATION_KEYS` order) from a frame's entries (copied: the caller may
        keep them for the frame's next control steps) and a step's (``residual_offset`` last, when it has one)."""
        obs = {k: frame_part[k].copy() if k in frame_part else step_part[k] for k in OBSERVATION_KEYS}
        if "residual_offset" in step_part:
            obs["residual_offset"] = step_part["residual_offset"]
        return obs


def _clip32(a: np.ndarray, bound: float) -> np.ndarray:
    """``a`` clipped to [−bound, bound], as float32: ``np.clip``'s value without its dispatch overhead."""
    return np.minimum(np.maximum(a, -bound), bound).astype(np.float32)
