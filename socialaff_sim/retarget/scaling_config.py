"""Settings of the human-to-robot key-joint mapping (:class:`~socialaff_sim.retarget.scaling.KeyJointScaler`)."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ConfigError

__all__ = ["ScalingConfig"]


@dataclass(frozen=True)
class ScalingConfig:
    """Settings of the human-to-robot mapping.

    Fields by concept
    -----------------
    - Wrist targets near contact: contact_near, contact_far, contact_push, object_lookahead, push_to_object
    - Placement of the robot: scale_placement, contact_placement, contact_radius, sample_band, max_extension,
      online_placement, placement_speed, approach_speed, approach_extension, k_min, k_max
    - Clearances: body_clearance, wrist_clearance
    """

    contact_near: float = 0.12
    """d_near [m]: at or below this wrist-to-partner distance the recorded wrist position is used."""
    contact_far: float = 0.6
    """d_far [m]: at or above this distance the scaled wrist position is used (a wide band keeps the
    blend from moving the target faster than the hand approaching the partner)."""
    contact_push: float = 0.05
    """δ [m]: in contact (weight w) the middle of the robot's hand is aimed w·δ beyond the middle of
    agent 1's, toward the nearest joint of agent 0, so that a hand shaped unlike a human one still
    closes the gap (the IK's contact limit stops it ``IKConfig.contact_depth`` into the person). The
    wrist target moves by δ_w = δ + hand_h − hand_r (the hands' lengths from the wrist; see
    :attr:`KeyJointScaler.push`), which after :meth:`KeyJointScaler.reset` is also the scaler's
    ``config.contact_push``."""
    object_lookahead: float = 0.25
    """[s]: the wrists react to the object's recorded track extrapolated this far ahead (a ballistic
    path from its last two frames; see :func:`object_anchors`), so that two hands close where a thrown
    ball is about to be rather than where it is."""
    push_to_object: bool = True
    """[—]: Whether the push also applies toward the object (two hands closing on a ball or a cup), not only
    toward the partner's joints."""
    scale_placement: bool = True
    """[—]: Whether the robot's distance to the partner is scaled by k (else agent 1's spot is used, k = 1)."""
    contact_placement: bool = True
    """[—]: Whether k comes from the contact samples (else, and without samples, from the arm ratio)."""
    contact_radius: float = 0.25
    """d_c [m]: a wrist of agent 1 whose closest approach to the partner (or the object) comes within
    this distance marks a contact, used to place the robot."""
    sample_band: float = 0.03
    """[m]: the frames within this distance of a contact's closest approach are its samples."""
    max_extension: float = 0.9
    """e_max [—]: the most a contact may stretch the robot's arm, as a fraction of its length."""
    online_placement: bool = True
    """[—]: Whether a robot placed without contact samples (a causal source shows only agent 1's first frames)
    moves in as the track it is given makes contact: each wrist within ``contact_radius`` of the partner
    or the object lowers k to what keeps that wrist within reach (never raises it)."""
    placement_speed: float = 0.6
    """v_p [m/s]: the most the online placement moves the robot's base toward the partner."""
    approach_speed: float = 1.0
    """v_a [m/s]: the most the online placement moves the base toward the partner in a frame where the source's
    model means to touch and the contact is beyond the robot's reach (:meth:`KeyJointScaler.approach`; a
    person's brisk walk)."""
    approach_extension: float | None = None
    """e_a [—]: with online placement, when no placement brings the contact the model means to make within
    ``max_extension`` of either arm (:meth:`KeyJointScaler.approach`; a raised palm higher above a short robot's
    shoulders than ``max_extension`` of its arm), the approach asks again with e_a times the arm's length and moves
    in toward that placement (the contact completion's reach is ``ContactCompletionConfig.reach``, 1.0 by default).
    ``None``: it stops there (the default; docs/design.md §5, issue 25, session 34, wip/demohf4). At least
    ``max_extension``."""
    k_min: float = 0.5
    """[—]: Smallest placement factor k."""
    k_max: float = 2.0
    """[—]: Largest placement factor k."""
    body_clearance: float = 0.15
    """c_b [m]: the robot's trunk (its ``trunk_radius`` about the base's vertical axis) keeps at
    least this far from the partner's trunk, head and legs joints at every frame (k is raised until
    it does: a robot must not stand where the person's body will be)."""
    wrist_clearance: float = 0.05
    """c_w [m]: at every contact sample agent 1's wrist (where the robot's wrist is sent in contact)
    lies at least ``trunk_radius`` + c_w horizontally from the robot's base axis (k is raised until it
    does: a ball caught at a person's chest must not be met inside a broader robot's chest)."""

    def __post_init__(self) -> None:
        if not self.placement_speed >= 0:
            raise ConfigError(f"ScalingConfig.placement_speed: expected a speed ≥ 0 m/s, found {self.placement_speed}")
        if not self.approach_speed >= 0:
            raise ConfigError(f"ScalingConfig.approach_speed: expected a speed ≥ 0 m/s, found {self.approach_speed}")
        if self.approach_extension is not None and not self.approach_extension >= self.max_extension:
            raise ConfigError(f"ScalingConfig.approach_extension: expected None or a fraction ≥ max_extension "
                              f"({self.max_extension}), found {self.approach_extension}")
        if not self.wrist_clearance >= 0:
            raise ConfigError(f"ScalingConfig.wrist_clearance: expected a distance ≥ 0 m, found {self.wrist_clearance}")
