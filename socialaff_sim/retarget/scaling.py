"""Human-to-robot scaling of the five key joints.

Frames. The *world* frame is the simulator's (the data frame shifted so that the
floor is z = 0). The *robot frame* is fixed at reset: origin on the floor under
the robot's base, x toward the human partner, z up. Targets handed to the IK and
to :meth:`Simulator.step` are in the robot frame, in metres.

Scaling. Agent 1's key joints are read in its own heading frame (origin under its
base at frame 0, x toward agent 0) and mapped limb by limb:

* base: horizontally, the vector from agent 0's base to agent 1's, × k (see
  placement); height: h_r + s_leg · (z − h_h);
* wrist: base + shoulder_r + s_arm · (wrist − base − shoulder_h);
* ankle: base + hip_r + s_leg · (ankle − base − hip_h);

with s_arm = arm_r / arm_h and s_leg = leg_r / leg_h the ratios of limb lengths
(shoulder→elbow→wrist and hip→knee→ankle, measured along the chains on both
bodies) and shoulder/hip offsets measured from the base at rest.

Placement. The robot keeps agent 1's bearing from the partner (p₀, the partner's
base) at every frame, at k times agent 1's distance: base = p₀ + k·(b₁ − p₀)
horizontally. k is chosen once per instance so that the interaction's contacts
stay within the robot's reach: at every contact sample (a frame where one of
agent 1's wrists is at, or within ``sample_band`` of, its closest approach to the
partner or the object, when that approach comes within ``contact_radius``) the
robot's shoulder must be within e·arm_r of agent 1's wrist, e the extension agent
1's own arm had there (|wrist − shoulder| / arm₁, at most ``max_extension``). Each
sample allows k in an interval (a quadratic in k); the robot stands as far back as
all samples allow (the smallest upper end), within [``k_min``, ``k_max``]. Samples
no k brings within reach (a contact far below a tall robot's shoulders, met by
bending) are left out. Without usable samples, k = (arm₀ + arm_r) / (arm₀ + arm₁),
so that its shorter (or longer) reach still meets the partner's. Either way k is
then at least what puts every sample's wrist ``trunk_radius`` + ``wrist_clearance``
horizontally from the robot's base axis (this lower bound wins over the reach's
upper one): in contact the robot's wrist is sent to agent 1's, and a ball caught at
a slim person's chest would otherwise be met inside a broader robot's chest. Finally k is
raised, if needed, until the robot's trunk clears the partner's trunk, head and
legs by ``body_clearance`` at every frame: the arms (and bending) must then make
up the distance, but the robot never stands where the person's body will be. This matters for a robot of unlike build: a short
robot with long arms meets a tall person's raised hand only from close by.

Online placement. A causal source (the model's synthesis reacting to the person) shows the
scaler only agent 1's first frames, usually without a contact, so k starts at the arm ratio. With
``online_placement`` the scaler then takes contact samples from the keys it is given, frame by
frame (a wrist within ``contact_radius`` of the partner or the object), and lowers k to the largest
value keeping them within reach (but their wrists clear of its trunk), the base moving in at most
``placement_speed``.

Contact preservation. Near the partner (or the object) the interaction, not the
body, sets where a wrist must be: each wrist target is blended toward agent 1's
unscaled wrist position with weight w = smoothstep((far − d) / (far − near)),
where d is the distance from agent 1's wrist to the nearest joint of agent 0 or
the object. Far from everything the scaled target is used; in contact, the
recorded one, pushed w·δ_w toward that nearest joint (or the object's centre)
so that the robot's hand closes the gap its different shape leaves (the IK
stops it at the person's surface; a ball or a cup is squeezed between two
hands). δ_w = δ + hand_h − hand_r aims the middle of the robot's hand, not its
wrist, δ beyond the middle of agent 1's hand: a robot hand reaching farther past
its wrist than a person's is held back by the difference.

The bounds on k (reach, trunk and body clearance) are computed in :mod:`~socialaff_sim.retarget.placement`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..data.interaction import Interaction
from .anchors import GRAVITY, LOOKAHEAD_POINTS, object_anchors
from .measure import BodyMeasurements, RobotFrame, heading_matrix, measure_human, measure_robot
from .placement import body_clearance_k, frame_clearance_k, is_body_joint, k_clear_of_trunk, k_within_reach
from .scaling_config import ScalingConfig

__all__ = [
    "ScalingConfig",
    "BodyMeasurements",
    "RobotFrame",
    "measure_human",
    "measure_robot",
    "KeyJointScaler",
    "smoothstep",
    "object_anchors",
    "LOOKAHEAD_POINTS",
    "GRAVITY",
]


def smoothstep(x: np.ndarray | float) -> np.ndarray:
    """3x² − 2x³ on [0, 1], clamped outside."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


class KeyJointScaler:
    """Maps agent 1's key joints (world frame) to robot-frame targets for one instance."""

    def __init__(self, robot: BodyMeasurements, config: ScalingConfig | None = None) -> None:
        self.robot = robot
        self._base_config = config or ScalingConfig()
        self.config = self._base_config
        self.push = self.config.contact_push
        self._online = False  # set by reset: whether k follows the contacts of the keys it is given

    def reset(self, inter: Interaction, offset: np.ndarray) -> RobotFrame:
        """Measure the instance's people and place the robot; returns the robot frame."""
        offset = np.asarray(offset, dtype=np.float64)
        key0 = inter.key_joints()[0] + offset  # (2, 5, 3) at frame 0
        self.human = measure_human(inter, 1, offset)
        partner = measure_human(inter, 0, offset)
        a0 = np.array([key0[0, 0, 0], key0[0, 0, 1], 0.0])
        a1 = np.array([key0[1, 0, 0], key0[1, 0, 1], 0.0])
        self._agent_frame = RobotFrame(a1, heading_matrix(a0 - a1))
        idx = inter.layout.key_indices[0]
        self._partner_base = 0 if idx is None else idx
        self._body = np.array([j for j, n in enumerate(inter.joint_names) if is_body_joint(n)], dtype=np.int64)
        """Agent 0's trunk, head and leg joints (the ones the robot's trunk keeps clear of)."""
        self.s_arm = self.robot.arm / self.human.arm
        self.s_leg = self.robot.leg / self.human.leg
        # The push is meant for the middle of the hand: a robot hand reaching farther past its wrist
        # than a person's needs its wrist held back by the difference (and a shorter one, pushed on).
        base = self._base_config
        self.push = base.contact_push + self.human.hand - self.robot.hand
        """Effective push δ_w of the wrist toward the partner in contact, metres (also ``config.contact_push``)."""
        self.config = dataclasses.replace(base, contact_push=self.push)
        c = self.config
        k = (partner.arm + self.robot.arm) / (partner.arm + self.human.arm)
        self.contact_k: float | None = None
        """k the contact samples' reach requires (``None`` without samples in reach or with contact placement off)."""
        self.trunk_k: float | None = None
        """Smallest k keeping the contact samples' wrists clear of the robot's trunk (``None`` when no sample
        bounds it or with contact placement off)."""
        if c.contact_placement:
            self.contact_k, self.trunk_k = self._contact_bounds(inter, offset, heading_matrix(a0 - a1))
            if self.contact_k is not None:
                k = self.contact_k
            if self.trunk_k is not None:
                k = max(k, self.trunk_k)
        if c.scale_placement and self.robot.trunk_radius > 0:
            k = max(k, body_clearance_k(inter, offset, self._partner_base, k, self.robot, c))
        self.k = float(np.clip(k, c.k_min, c.k_max)) if c.scale_placement else 1.0
        self._online = c.online_placement and c.contact_placement and c.scale_placement and self.contact_k is None
        # Moving in never undercuts the trunk's clearance from the person (over the frames placed from).
        self._k_floor = c.k_min
        if self._online and self.robot.trunk_radius > 0:
            self._k_floor = max(body_clearance_k(inter, offset, self._partner_base, c.k_min, self.robot, c),
                                self.trunk_k or c.k_min)
        self._k_step = c.placement_speed / max(inter.fps, 1e-9)  # metres of base motion per frame
        self._approach_step = c.approach_speed / max(inter.fps, 1e-9)
        self.stand_cap = np.inf
        """Metres: the most the robot's base stands from the partner's horizontally, lowered by :meth:`approach`
        (the model's own placement applies within it)."""
        self._k_goal = self.k
        origin = a0 + (a1 - a0) * self.k
        self.frame = RobotFrame(origin, heading_matrix(a0 - a1))
        return self.frame

    def _contact_bounds(self, inter: Interaction, offset: np.ndarray, rotation: np.ndarray
                        ) -> tuple[float | None, float | None]:
        """The largest k keeping every contact sample within the robot's reach and the smallest keeping their
        wrists clear of its trunk (see the module notes); ``None`` where no sample bounds k."""
        c = self.config
        joints = inter.filled_joints() + offset  # (T, 2, J, 3)
        keys = inter.key_joints()[:, 1] + offset  # (T, 5, 3)
        partner = joints[:, 0]
        anchors = partner if inter.object is None else np.concatenate([partner, (inter.object + offset)[:, None]], axis=1)
        dist = np.linalg.norm(keys[:, 1:3, None, :] - anchors[:, None, :, :], axis=-1)  # (T, 2, A)
        closest = np.min(np.where(np.isfinite(dist), dist, np.inf), axis=2)  # (T, 2)
        # A wrist whose closest approach comes within contact_radius touches there: its samples are the
        # frames within sample_band of that approach (or within contact_near).
        approach = closest.min(axis=0)  # (2,)
        near = (closest <= np.maximum(c.contact_near, approach + c.sample_band)) & (approach <= c.contact_radius)
        t_idx, side = np.nonzero(near)
        if not len(t_idx):
            return None, None
        wrist = keys[t_idx, 1 + side]
        base1 = keys[t_idx, 0]
        p0 = partner[t_idx, self._partner_base]
        ok = np.isfinite(wrist).all(axis=1) & np.isfinite(base1).all(axis=1) & np.isfinite(p0).all(axis=1)
        if not ok.any():
            return None, None
        t_idx, side, wrist, base1, p0 = t_idx[ok], side[ok], wrist[ok], base1[ok], p0[ok]
        names = inter.joint_names
        shoulder_h = self._shoulders(base1, side)
        for s, name in enumerate(("left_shoulder", "right_shoulder")):
            if name in names:
                rows = side == s
                measured = joints[t_idx[rows], 1, names.index(name)]
                good = np.isfinite(measured).all(axis=1)
                shoulder_h[np.flatnonzero(rows)[good]] = measured[good]
        return self._bounds(wrist, base1, p0, side, shoulder_h, rotation)

    def _shoulders(self, base1: np.ndarray, side: np.ndarray) -> np.ndarray:
        """(N, 3) agent 1's ``side`` (N,) shoulder, world frame, from its base ``base1`` (N, 3) and its
        measured offset (where the recording has no shoulder joint to read)."""
        return base1 + self.human.shoulders[side] @ self._agent_frame.rotation.T

    def _bounds(self, wrist: np.ndarray, base1: np.ndarray, p0: np.ndarray, side: np.ndarray,
                shoulder_h: np.ndarray, rotation: np.ndarray) -> tuple[float | None, float | None]:
        """Of N contact samples (agent 1's ``wrist``, ``base1`` and ``shoulder_h``, agent 0's base ``p0`` (N, 3)
        world frame, the wrist's ``side`` (N,), the robot frame's ``rotation``): the largest k keeping them
        within reach, each using the extension agent 1's arm had there (at most ``max_extension``), and the
        smallest keeping their wrists clear of the robot's trunk (``None`` where no bound)."""
        c = self.config
        extension = np.minimum(np.linalg.norm(wrist - shoulder_h, axis=1) / self.human.arm, c.max_extension)
        return (k_within_reach(wrist, base1, p0, side, rotation, self.robot, self.human, self.s_leg, extension),
                k_clear_of_trunk(wrist, base1, p0, self.robot.trunk_radius, c.wrist_clearance))

    def _place_online(self, keys: np.ndarray, d: np.ndarray, p0: np.ndarray) -> None:
        """Lower k toward what the wrists within ``contact_radius`` (distances ``d`` (2,)) of agent 1's
        ``keys`` (5, 3) need, agent 0's base at ``p0`` (3,), all world frame (see the module notes)."""
        c = self.config
        side = np.flatnonzero(d <= c.contact_radius)
        if len(side) and np.isfinite(keys[0]).all() and np.isfinite(keys[1 + side]).all():
            base1 = np.repeat(keys[None, 0], len(side), axis=0)
            k, front = self._bounds(keys[1 + side], base1, np.repeat(p0[None], len(side), axis=0), side,
                                    self._shoulders(base1, side), self.frame.rotation)
            if k is not None:
                self._k_goal = min(self._k_goal, max(k, self._k_floor, -np.inf if front is None else front))
        if self._k_goal < self.k:
            spread = float(np.linalg.norm(keys[0, :2] - p0[:2])) if np.isfinite(keys[0]).all() else 0.0
            self.k = max(self._k_goal, self.k - self._k_step / max(spread, 1e-3))

    def approach(self, points: np.ndarray, side: np.ndarray, keys: np.ndarray, partner: np.ndarray,
                 flight: bool = False) -> bool:
        """Move in toward contacts the source means to make but the robot cannot reach from where it stands.

        ``points`` (N, 3): where the robot's ``side`` (N,) hands are to touch (the person's hand, the object; the
        robot's other hand may touch instead, whichever needs the robot to move in less),
        ``keys`` (5, 3) agent 1's key joints from the source and ``partner`` (J, 3) agent 0's joints, all
        world frame and of the current frame. With online placement, k is lowered to the largest value that
        brings every point within ``max_extension`` of the robot's arm from its shoulder (never below what keeps
        its trunk clear of the person and of the points): the cap on the base's distance from the partner
        (``stand_cap``) comes down by up to ``approach_speed`` toward that k's distance. The robot stops moving
        in when the calls stop, and where the model itself brings agent 1 closer the cap no longer acts (the
        two approaches do not add up). ``flight``: the points are a ball's predicted flight, which the placement from
        the recording did not see: the robot moves in also without online placement, and the floor the recording's
        contact samples set (their wrists clear of the robot's trunk: a ball held at the chest) does not hold it
        back (the points' own clearance of the trunk and the person's body still do). Returns whether it lowered the
        cap (False: no online placement and not ``flight``, or no k reaches)."""
        keys = np.asarray(keys, dtype=np.float64)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        side = np.asarray(side, dtype=np.int64).reshape(-1)
        p0 = np.asarray(partner, dtype=np.float64)[self._partner_base]
        if not ((self._online or flight) and len(points) and np.isfinite(keys[0]).all() and np.isfinite(points).all()
                and np.isfinite(p0).all()):
            return False
        n = len(points)
        base1 = np.repeat(keys[None, 0], n, axis=0)
        p0s = np.repeat(p0[None], n, axis=0)
        # Either of the robot's hands may make the contact: the robot moves in only as far as the nearer needs.
        finite = self._reaching(points, side, base1, p0s, self.config.max_extension)
        if not finite and self.config.approach_extension is not None:  # too high (or low) for max_extension
            finite = self._reaching(points, side, base1, p0s, self.config.approach_extension)
        if not finite:
            return False
        k = max(finite)
        front = k_clear_of_trunk(points, base1, p0s, self.robot.trunk_radius, self.config.wrist_clearance)
        body = np.asarray(partner, dtype=np.float64)[self._body]
        goal = max(k, self.config.k_min if flight else self._k_floor, -np.inf if front is None else front,
                   frame_clearance_k(body, keys[0], p0, self.k, self.robot, self.config))
        spread = float(np.linalg.norm(keys[0, :2] - p0[:2]))
        now = min(self.stand_cap, self.k * spread)
        if goal * spread >= now:
            return False
        self.stand_cap = max(goal * spread, now - self._approach_step)
        return True

    def _reaching(self, points: np.ndarray, side: np.ndarray, base1: np.ndarray, p0s: np.ndarray,
                  extension: float) -> list[float]:
        """The placement factors (those not ``None``) that bring ``points`` (N, 3) within ``extension`` of the arm
        of the robot's ``side`` (N,) hands, and of its other hands (agent 1's base ``base1``, agent 0's ``p0s``)."""
        reach = np.full(len(points), float(extension))
        ks = [k_within_reach(points, base1, p0s, s, self.frame.rotation, self.robot, self.human, self.s_leg, reach)
              for s in (side, 1 - side)]
        return [v for v in ks if v is not None]

    def approach_nearest(self, points: np.ndarray, keys: np.ndarray, partner: np.ndarray, flight: bool = False) -> bool:
        """:meth:`approach` toward the one of ``points`` (N, 3) that needs the least moving in (the largest k that
        brings it within ``max_extension`` of either hand's shoulder; a ball's predicted path, of which one point
        is to be met). Returns whether the cap was lowered (False also when no k brings any point within reach)."""
        keys = np.asarray(keys, dtype=np.float64)
        p0 = np.asarray(partner, dtype=np.float64)[self._partner_base]
        if not (np.isfinite(keys[0]).all() and np.isfinite(p0).all()):
            return False
        best: tuple[float, int, int] | None = None
        reach = np.array([self.config.max_extension])
        for side in (0, 1):
            for i, point in enumerate(np.asarray(points, dtype=np.float64).reshape(-1, 3)):
                k = k_within_reach(point[None], keys[None, 0], p0[None], np.array([side]), self.frame.rotation,
                                   self.robot, self.human, self.s_leg, reach)
                if k is not None and (best is None or k > best[0]):
                    best = (k, i, side)
        if best is None:
            return False
        return self.approach(np.asarray(points, dtype=np.float64).reshape(-1, 3)[best[1]], np.array([best[2]]), keys,
                             partner, flight=flight)

    def scaled(self, keys: np.ndarray, partner_base: np.ndarray) -> np.ndarray:
        """(5, 3) robot-frame targets from agent 1's key joints ``keys`` (5, 3), world frame, by scaling alone.

        ``partner_base`` (3,): agent 0's base at the same frame, world frame.
        """
        h, r = self.human, self.robot
        keys = np.asarray(keys, dtype=np.float64)
        local = self._agent_frame.to_robot(keys)
        base = local[0]
        p0 = np.asarray(partner_base, dtype=np.float64)
        k = self.k
        spread = float(np.linalg.norm(keys[0, :2] - p0[:2]))
        if np.isfinite(self.stand_cap) and spread > 1e-6:
            k = min(k, self.stand_cap / spread)
        placed = self.frame.to_robot(p0 + k * (keys[0] - p0))
        out = np.empty((5, 3))
        out[0] = (placed[0], placed[1], r.base_height + self.s_leg * (base[2] - h.base_height))
        out[1:3] = out[0] + r.shoulders + self.s_arm * (local[1:3] - base - h.shoulders)
        out[3:5] = out[0] + r.hips + self.s_leg * (local[3:5] - base - h.hips)
        return out

    def _nearest(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance (2,), nearest anchor (2, 3) and whether it is a joint of agent 0 (2,) for each wrist."""
        anchors = partner if obj is None else np.vstack([partner, np.asarray(obj, dtype=np.float64).reshape(-1, 3)])
        is_joint = np.arange(len(anchors)) < len(partner)
        ok = np.isfinite(anchors).all(axis=1)
        anchors, is_joint = anchors[ok], is_joint[ok]
        if len(anchors) == 0:
            return np.full(2, np.inf), np.zeros((2, 3)), np.zeros(2, dtype=bool)
        d = np.linalg.norm(keys[1:3, None, :] - anchors[None], axis=-1)
        j = d.argmin(axis=1)
        return d[[0, 1], j], anchors[j], is_joint[j]

    def contact_weights(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None = None) -> np.ndarray:
        """(2,) blend weight of the recorded position for the left and right wrist.

        ``partner`` (J, 3): agent 0's joints; ``obj`` (3,) or (K, 3) (the object and, e.g., where it is
        about to be; see :func:`object_anchors`) or ``None``; all world frame.
        """
        d, _, _ = self._nearest(np.asarray(keys, dtype=np.float64), partner, obj)
        c = self.config
        return smoothstep((c.contact_far - d) / (c.contact_far - c.contact_near))

    def __call__(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None = None) -> np.ndarray:
        """(5, 3) robot-frame targets: scaled, with wrists blended toward the recording near contacts."""
        keys = np.asarray(keys, dtype=np.float64)
        p0 = partner[self._partner_base]
        if not np.isfinite(p0).all():
            p0 = self.frame.origin + self.frame.rotation[:, 0]
        c = self.config
        d, anchor, is_joint = self._nearest(keys, partner, obj)
        if self._online:
            self._place_online(keys, d, p0)
        out = self.scaled(keys, p0)
        w = smoothstep((c.contact_far - d) / (c.contact_far - c.contact_near))
        recorded = keys[1:3].copy()
        toward = anchor - recorded
        n = np.linalg.norm(toward, axis=1, keepdims=True)
        unit = np.divide(toward, n, out=np.zeros_like(toward), where=n > 1e-9)
        pushed = is_joint | c.push_to_object
        recorded += (w * c.contact_push * pushed)[:, None] * unit
        out[1:3] = w[:, None] * self.frame.to_robot(recorded) + (1.0 - w[:, None]) * out[1:3]
        return out
