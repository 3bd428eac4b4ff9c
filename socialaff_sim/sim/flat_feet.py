"""Feet held flat on their soles: the balance QP's contact model and hard constraints for ``BalanceConfig.flat_feet``.

Traced step by step, the planted feet of a robot under the balance controller do not creep across the floor
so much as rock and pivot on their soles' edges: a foot tipped by a degree or two touches the floor at one or
two corners only, the inverse dynamics can then put its force only there, and its ankle's torque (computed for
those corners) keeps it tipped. With ``flat_feet`` the controller instead models every planted foot that is on
the floor (in contact, or its sole within ``sole_gap`` of it) as standing flat on its whole sole:

* the contact points are the sole's four corners (:func:`sole_corners`, found at home from the foot's contacts
  with the floor), with the floor's normal and friction cones, whatever corners MuJoCo's contacts touch now; the
  centre-of-pressure bounds then hold ``cop_margin`` inside the whole sole, so the ankle never asks the floor to
  push at an edge;
* the foot's six-dimensional acceleration is a hard equality of the QP (:func:`foot_rows`): toward where it
  stood, at the home ankle height, with the sole level (the attitude it has at home, turned about the vertical
  to its heading when it came down, :func:`flat_attitude`), as the stiffness and damping of the feet's task ask,
  the Jacobian's drift ``J̇q̇`` included. The QP can no longer buy the centre of mass's acceleration by tipping a
  foot onto an edge.

The functions here are geometry only; :class:`~.balance_control.BalanceController` calls them.
"""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np

from ..retarget.kinematic_tree import ancestry

__all__ = ["flat_attitude", "flat_contacts", "foot_drift", "foot_feedback", "foot_rows", "free_roll", "leg_dofs", "roll_free_axes",
           "roll_freed", "sole_corners", "sole_points", "yaw_rows"]

_LEVEL_FRAME = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""A level floor's contact frame: the normal (+z), then the world's x and y as tangents."""


def sole_corners(sole: np.ndarray) -> np.ndarray:
    """(4, 3) the bottom corners of a sole box ``sole`` (8, 3) (foot body frame, m; as the controller finds it
    at home): the lowest face's corners, heel-left, heel-right, toe-left, toe-right order of the box's extent."""
    lo, hi = sole.min(axis=0), sole.max(axis=0)
    return np.array([[x, y, lo[2]] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])])


def sole_points(pos: np.ndarray, rot: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points (4, 3) of a foot's sole ``corners`` (4, 3) (body frame) at the foot's pose ``pos`` (3,),
    ``rot`` (3, 3), and their contact frames (4, 3, 3): the floor's normal (+z) first, then the world's x and y
    as tangents (the rows of MuJoCo's ``contact.frame`` for a level floor)."""
    pts = pos + corners @ rot.T
    frames = _LEVEL_FRAME[None].repeat(len(corners), axis=0)
    return pts, frames


def flat_attitude(rot: np.ndarray, home_rot: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """(3, 3) the attitude of a foot standing level: its home attitude ``home_rot`` (3, 3; the robot facing +x)
    turned about the vertical to the heading of ``rot`` (3, 3), the foot's axis ``forward`` (3,) (body frame;
    +x of the world at home) projected on the floor."""
    f = rot @ forward
    yaw = math.atan2(float(f[1]), float(f[0]))
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ home_rot


def foot_feedback(m: mujoco.MjModel, d: mujoco.MjData, body: int, vadr: np.ndarray, goal_pos: np.ndarray,
                  goal_rot: np.ndarray, stiffness: float, damping: float,
                  scratch: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(J (6, n), b (6,)): a foot's Jacobian on the robot's coordinates ``vadr`` (n,), rows linear then angular
    (world), and its feedback ``k_x`` (``stiffness``, 1/s²) times the displacement to ``goal_pos`` (3,) and the
    rotation vector to ``goal_rot`` (3, 3) minus ``k_f`` (``damping``, 1/s) times the foot's velocity: the planted
    foot's task of the balance controller, and :func:`foot_rows` without the drift. ``scratch``: a (6, nv) array,
    room for the Jacobian (MuJoCo overwrites it whole; ``None``: allocated here)."""
    jac = np.empty((6, m.nv)) if scratch is None else scratch
    mujoco.mj_jacBody(m, d, jac[:3], jac[3:], body)
    J = jac[:, vadr]
    quat, vel = np.empty(4), np.empty(3)  # (MuJoCo writes them whole)
    mujoco.mju_mat2Quat(quat, (goal_rot @ d.xmat[body].reshape(3, 3).T).ravel())
    mujoco.mju_quat2Vel(vel, quat, 1.0)
    off = np.concatenate([goal_pos - d.xpos[body], vel])
    return J, stiffness * off - damping * (J @ d.qvel[vadr])


def foot_drift(m: mujoco.MjModel, d: mujoco.MjData, body: int, scratch: np.ndarray | None = None) -> np.ndarray:
    """(6,) the drift ``J̇q̇`` of a foot's Jacobian (rows linear then angular, world; m/s², rad/s²); ``scratch``: a
    (6, nv) array, room for ``J̇`` (``None``: allocated here)."""
    dot = np.empty((6, m.nv)) if scratch is None else scratch
    mujoco.mj_jacDot(m, d, dot[:3], dot[3:], d.xpos[body], body)
    return dot @ d.qvel


def foot_rows(m: mujoco.MjModel, d: mujoco.MjData, body: int, vadr: np.ndarray, goal_pos: np.ndarray,
              goal_rot: np.ndarray, stiffness: float, damping: float,
              scratch: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(A (6, n), b (6,)) rows ``A q̈ = b`` of a foot's wanted acceleration, on the robot's coordinates ``vadr``
    (n,): linear and angular (world), ``k_x`` (``stiffness``, 1/s²) times the displacement to ``goal_pos`` (3,)
    and the rotation vector to ``goal_rot`` (3, 3), minus ``k_f`` (``damping``, 1/s) times the foot's velocity,
    minus the drift ``J̇q̇`` (so that ``J q̈ + J̇ q̇`` is what is asked): :func:`foot_feedback` minus
    :func:`foot_drift`. ``scratch``: two (6, nv) arrays, room for the Jacobian and its derivative (MuJoCo
    overwrites them whole; ``None``: allocated here)."""
    jac, dot = (None, None) if scratch is None else scratch
    J, b = foot_feedback(m, d, body, vadr, goal_pos, goal_rot, stiffness, damping, jac)
    return J, b - foot_drift(m, d, body, dot)


def flat_contacts(m: mujoco.MjModel, d: mujoco.MjData, feet: list[int], corners: list[np.ndarray | None],
                  anchors: list[tuple[np.ndarray, np.ndarray]], vadr: np.ndarray, pts: np.ndarray, frames: np.ndarray,
                  which: np.ndarray, sole_gap: float, stiffness: float, damping: float,
                  scratch: tuple[np.ndarray, np.ndarray] | None = None,
                  feedback: list[tuple[np.ndarray, np.ndarray]] | None = None,
                  roll_free: list[np.ndarray | None] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """The contacts of a standing robot with its feet held flat (the module docstring).

    ``feet``: the feet's bodies; ``corners``: each one's :func:`sole_corners` (``None``: sole unknown, its live
    contacts kept); ``anchors``: each one's level goal (position (3,), attitude (3, 3)); ``vadr`` (n,) the robot's
    coordinates; ``pts`` (P, 3), ``frames`` (P, 3, 3), ``which`` (P,): the live contacts with the floor and their
    foot (not empty); a foot with live contacts, or whose lowest corner is within ``sole_gap`` (+ 2 mm) of the
    lowest live contact, has them replaced by its sole's corners and gets the hard rows of :func:`foot_rows`.
    Returns the contact points, frames and feet, and the stacked rows (``None``: no such foot). ``scratch``: as
    :func:`foot_rows`'; ``feedback``: each foot's :func:`foot_feedback` toward its anchor with these gains, when
    the caller has it already (the balance controller's feet's tasks): only the drift is then computed here.
    ``roll_free`` (``BalanceConfig.flat_roll_free``): per foot its forward axis (3,, body frame) where its rows leave
    out the roll about it (:func:`free_roll`), ``None`` where all six hold; ``None``: all six for every foot."""
    floor = float(pts[:, 2].min())
    keep = np.ones(len(pts), dtype=bool)
    add_p, add_f, add_w, rows = [], [], [], []
    for s, body in enumerate(feet):
        c = corners[s]
        if c is None:
            continue
        p, f = sole_points(d.xpos[body], d.xmat[body].reshape(3, 3), c)
        if not (which == s).any() and float(p[:, 2].min()) > floor + sole_gap + 0.002:
            continue
        mine = which == s
        keep &= ~mine
        add_p.append(p)
        add_f.append(f)
        add_w.append(np.full(len(p), s, dtype=np.int64))
        if feedback is None:
            J, b = foot_rows(m, d, body, vadr, anchors[s][0], anchors[s][1], stiffness, damping, scratch)
        else:
            J, b = feedback[s]
            b = b - foot_drift(m, d, body, None if scratch is None else scratch[1])
        axis = None if roll_free is None else roll_free[s]
        rows.append((J, b) if axis is None else free_roll(J, b, d.xmat[body].reshape(3, 3) @ axis))
    if not rows:
        return pts, frames, which, None
    return (np.vstack([pts[keep], *add_p]), np.concatenate([frames[keep], *add_f]),
            np.concatenate([which[keep], *add_w]), (np.vstack([r[0] for r in rows]), np.concatenate([r[1] for r in rows])))


def leg_dofs(m: mujoco.MjModel, foot: int, root: int) -> int:
    """The joint degrees of freedom between the body ``root`` (exclusive: its own joints, the free joint, not
    counted) and the body ``foot`` (inclusive): six or more let a leg put its foot in any pose relative to the root;
    the H1's legs have five (no ankle roll)."""
    return sum(int(m.body_dofnum[b]) for b in itertools.takewhile(lambda b: b != root, ancestry(m, int(foot))))


def roll_free_axes(m: mujoco.MjModel, feet: list[int], forward: np.ndarray, root: int) -> list[np.ndarray | None]:
    """``BalanceConfig.flat_roll_free``'s feet: per foot of ``feet`` its forward axis ``forward[i]`` (3,, body frame)
    where its leg has fewer than six degrees of freedom from ``root`` (:func:`leg_dofs`: it cannot roll the foot on
    its own), else ``None`` (its six hard rows stay)."""
    return [np.asarray(fw, dtype=np.float64) if leg_dofs(m, int(b), root) < 6 else None
            for b, fw in zip(feet, forward, strict=True)]


def roll_freed(roll_free: list[np.ndarray | None] | None) -> bool:
    """Whether :func:`roll_free_axes`'s ``roll_free`` (``None``: ``flat_roll_free`` off) frees some foot's roll: the
    robots (the H1, not Stubby) that the ``*_roll_free`` gates pick."""
    return roll_free is not None and any(a is not None for a in roll_free)


def free_roll(J: np.ndarray, b: np.ndarray, forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A foot's six hard rows (``J`` (6, n), ``b`` (6,): linear then angular, world, as :func:`foot_rows`) with the
    roll about the foot's horizontal forward axis left out: the angular rows turned onto the axes (forward,
    lateral, vertical) of ``forward`` (3,) (the foot's forward axis in the world, projected on the floor), the roll's
    row and value made zero (the QP's solve drops an empty row), the vertical (yaw) row kept sixth. New arrays."""
    f = np.array([forward[0], forward[1], 0.0])
    f /= max(float(np.linalg.norm(f)), 1e-12)
    lat = np.array([-f[1], f[0], 0.0])
    A, v = J.copy(), b.copy()
    A[3], A[4] = 0.0, lat @ J[3:6]
    v[3], v[4] = 0.0, float(lat @ b[3:6])
    return A, v


def yaw_rows(rows: int) -> np.ndarray:
    """(rows,) bool: the rows of the turn about the vertical among :func:`flat_contacts`' stacked hard rows (six per
    foot, linear then angular, world: each foot's sixth)."""
    return np.arange(rows) % 6 == 5
