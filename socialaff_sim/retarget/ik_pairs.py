"""Which geom pairs the retargeting IK keeps apart, and how far: the rows of its :class:`~.collision.GeomPairLimit`.

The IK model's collidable geoms fall into groups (:class:`GeomGroups`): the person, the robot's trunk (every
robot geom but the forearms and hands), each arm (forearm and hand), each hand, and each leg (thigh, shin and
foot, which are also trunk geoms). The pairs, each with its distance ``d_min`` (:class:`~.ik_config.IKConfig`):

* trunk and person: ``min_distance``, pushed out when the person moves in;
* each arm and the person: ``min_distance``, except that the hand may press ``contact_depth`` into the parts
  a sub-goal wants touched (held, not pushed);
* each arm and the rest of the robot: ``min_distance``, pushed out with ``push_self`` (else held);
* the left leg and the right leg: ``leg_clearance``, pushed apart.

:func:`set_collision_bits` sets the model's contype/conaffinity bits so that MuJoCo's collision detection
finds these pairs and no other: trunk pairs other than the legs' never reach the narrow phase.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from .collision import GeomPairLimit, collision_pairs
from .ik_config import IKConfig

__all__ = ["GeomGroups", "set_collision_bits", "arm_self_pairs", "pair_limit"]


@dataclass(frozen=True)
class GeomGroups:
    """Geom ids of the IK model, grouped as its collision avoidance treats them."""

    human: np.ndarray
    """The person's geoms."""
    robot: np.ndarray
    """Every collidable robot geom."""
    arms: tuple[np.ndarray, np.ndarray]
    """The left and right forearm and hand."""
    hands: tuple[np.ndarray, np.ndarray]
    """The left and right hand."""
    legs: tuple[np.ndarray, np.ndarray]
    """The left and right leg's collidable geoms (none of an arm's); empty: no leg pairs."""

    @classmethod
    def of(cls, human: np.ndarray, robot: np.ndarray, arms: Sequence[np.ndarray], hands: Sequence[np.ndarray],
           legs: Sequence[np.ndarray]) -> GeomGroups:
        """The groups from geom id lists (legs restricted to collidable robot geoms outside the arms)."""
        ids = [np.asarray(x, dtype=np.int64) for x in (human, robot)]
        arm = tuple(np.asarray(a, dtype=np.int64) for a in arms)
        both = np.concatenate(arm)
        leg = tuple(np.setdiff1d(np.intersect1d(np.asarray(g, dtype=np.int64), ids[1]), both) for g in legs)
        return cls(ids[0], ids[1], (arm[0], arm[1]), (np.asarray(hands[0], dtype=np.int64),
                                                      np.asarray(hands[1], dtype=np.int64)), (leg[0], leg[1]))

    @property
    def trunk(self) -> np.ndarray:
        """Every collidable robot geom but the forearms' and hands'."""
        return np.setdiff1d(self.robot, np.concatenate(self.arms))


def set_collision_bits(model: mujoco.MjModel, groups: GeomGroups, legs: bool) -> None:
    """Let MuJoCo's collision detection in ``model`` find only the pairs the IK watches.

    Bits: person (contype 2, conaffinity 0); trunk (1, 2: the person only); forearms and hands (4, 7: the
    person, the trunk and each other). With ``legs``, the left leg's geoms are trunk geoms with contype bit 8
    and the right leg's with conaffinity bit 8, so that the two legs (and no other trunk pair) meet. Trunk
    pairs and the person's own pairs never reach the narrow phase.
    """
    sets = [(groups.human, 2, 0), (groups.trunk, 1, 2), (np.concatenate(groups.arms), 4, 7)]
    if legs:
        sets += [(groups.legs[0], 1 | 8, 2), (groups.legs[1], 1, 2 | 8)]
    for geoms, contype, conaffinity in sets:
        model.geom_contype[geoms] = contype
        model.geom_conaffinity[geoms] = conaffinity
    for b in np.unique(model.geom_bodyid[np.concatenate([groups.human, groups.robot])]):
        mine = model.geom_bodyid == b
        model.body_contype[b] = np.bitwise_or.reduce(model.geom_contype[mine])
        model.body_conaffinity[b] = np.bitwise_or.reduce(model.geom_conaffinity[mine])


def arm_self_pairs(model: mujoco.MjModel, groups: GeomGroups) -> list[np.ndarray]:
    """(P, 2) pairs of each arm's geoms and the rest of the robot's that can collide (bits as set)."""
    return [collision_pairs(model, groups.arms[s], np.setdiff1d(groups.robot, groups.arms[s])) for s in (0, 1)]


def pair_limit(model: mujoco.MjModel, groups: GeomGroups, self_pairs: Sequence[np.ndarray],
               free: Mapping[int, set[int]], config: IKConfig) -> GeomPairLimit:
    """The IK's collision limit: the pairs of the module notes, ``free[s]`` the person's geoms hand ``s`` may
    touch, ``self_pairs`` the arms' (:func:`arm_self_pairs`)."""
    c = config
    human, robot = groups.human, groups.robot
    parts: list[tuple[np.ndarray, float, float, bool]] = [
        (collision_pairs(model, groups.trunk, human), c.min_distance, c.detection_distance, True)]
    for s in (0, 1):
        arm = groups.arms[s]
        touch = np.array(sorted(free.get(s, set())), dtype=np.int64)
        hand = np.intersect1d(arm, groups.hands[s])
        # Only the hand may touch the wanted parts; the forearm keeps clear of them like of the rest.
        # A hand or forearm the person moves into is held, not pushed: around a hand in contact the
        # person's capsules surround it from several sides, and pushes would contradict each other.
        clear = np.concatenate([collision_pairs(model, arm, np.setdiff1d(human, touch)),
                                collision_pairs(model, np.setdiff1d(arm, hand), touch)])
        parts.append((clear, c.min_distance, c.detection_distance, False))
        if c.contact_depth is not None:
            parts.append((collision_pairs(model, hand, touch), -c.contact_depth, c.detection_distance, False))
        parts.append((self_pairs[s], c.min_distance, c.self_detection_distance, c.push_self))
    if c.leg_clearance is not None:
        # Unlike an arm against the body, the legs may be found inside each other (ankle targets of a recording
        # with crossed ankles draw the feet together from the first frame on): they are pushed apart.
        parts.append((collision_pairs(model, groups.legs[0], groups.legs[1]), c.leg_clearance,
                      c.self_detection_distance, True))
    pairs = np.concatenate([p for p, *_ in parts])
    # A geom pair listed twice (a forearm against the other forearm) keeps one row.
    _, first = np.unique(np.sort(pairs, axis=1), axis=0, return_index=True)
    first.sort()

    def column(k: int) -> np.ndarray:
        return np.concatenate([np.full(len(p[0]), p[k]) for p in parts])[first]

    # Contact margins (MuJoCo adds a pair's two): person–robot pairs reach the detection
    # distance, robot–robot pairs the (shorter) self-detection distance.
    margins = np.zeros(model.ngeom)
    half_self = 0.5 * c.self_detection_distance
    margins[robot] = half_self
    margins[human] = max(c.detection_distance - half_self, 0.0)
    return GeomPairLimit(model, pairs[first], column(1), column(2), column(3),
                         gain=c.collision_gain, max_push=c.max_push, margins=margins)
