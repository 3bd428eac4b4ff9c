"""The feet's hard rows without the roll a five-joint leg cannot make (``BalanceConfig.flat_roll_free``,
sim/flat_feet.py: leg_dofs, roll_free_axes, free_roll): the legs' degrees of freedom counted on a model written out
here, the roll's row against the angular rows turned by hand onto the foot's axes, and flat_contacts' rows per foot."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.flat_feet import flat_contacts, free_roll, leg_dofs, roll_free_axes, yaw_rows
from test_flat_feet import _pressed_at_home

_LEGS = """
<mujoco><worldbody><body name="pelvis" pos="0 0 1"><freejoint/>
  <geom type="sphere" size="0.1"/>
  <body name="l_hip" pos="0 0.1 0"><joint type="hinge" axis="0 0 1"/><joint type="hinge" axis="1 0 0"/>
    <joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
    <body name="l_shin" pos="0 0 -0.4"><joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
      <body name="l_foot" pos="0 0 -0.4"><joint type="hinge" axis="0 1 0"/><geom type="box" size="0.1 0.04 0.02"/></body>
    </body></body>
  <body name="r_hip" pos="0 -0.1 0"><joint type="hinge" axis="0 0 1"/><joint type="hinge" axis="1 0 0"/>
    <joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
    <body name="r_shin" pos="0 0 -0.4"><joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
      <body name="r_foot" pos="0 0 -0.4"><joint type="hinge" axis="0 1 0"/><joint type="hinge" axis="1 0 0"/>
        <geom type="box" size="0.1 0.04 0.02"/></body>
    </body></body>
</body></worldbody></mujoco>
"""


def _legs() -> tuple[mujoco.MjModel, int, int, int]:
    m = mujoco.MjModel.from_xml_string(_LEGS)
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in ("pelvis", "l_foot", "r_foot")]
    return m, ids[0], ids[1], ids[2]


def test_leg_dofs_counts_the_joints_between_the_root_and_the_foot() -> None:
    # Left: hip yaw, roll, pitch, knee, ankle pitch (five, as the H1's); right: and an ankle roll (six); the root's
    # free joint not counted.
    m, root, left, right = _legs()
    assert leg_dofs(m, left, root) == 5
    assert leg_dofs(m, right, root) == 6


def test_only_the_foot_whose_leg_has_fewer_than_six_dofs_gets_its_roll_freed(scene) -> None:
    m, root, left, right = _legs()
    fw = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    axes = roll_free_axes(m, [left, right], fw, root)
    assert axes[0] is not None and np.allclose(axes[0], fw[0])
    assert axes[1] is None
    # Stubby's legs have six joints each: nothing changes for it.
    feet = FeetOnFloor(scene, 0.0)
    assert [leg_dofs(scene.model, int(b), scene.root_body) for b in feet.bodies] == [6, 6]
    assert roll_free_axes(scene.model, feet.bodies, feet.forward, scene.root_body) == [None, None]


def test_free_roll_leaves_out_the_turn_about_the_feet_forward_axis_only(rng) -> None:
    n = 9
    J, b = rng.normal(size=(6, n)), rng.normal(size=6)
    yaw = math.radians(30.0)
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.2])  # tipped up: its floor projection is the axis
    A, v = free_roll(J, b, forward)
    # by hand: the frame (forward on the floor, lateral, up)
    f = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    R = np.array([f, [-math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(A[:3], J[:3])
    np.testing.assert_allclose(v[:3], b[:3])
    np.testing.assert_allclose(A[3], 0.0)
    assert v[3] == 0.0
    np.testing.assert_allclose(A[4], (R @ J[3:6])[1], atol=1e-12)
    np.testing.assert_allclose(v[4], (R @ b[3:6])[1], atol=1e-12)
    np.testing.assert_allclose(A[5], J[5])
    assert v[5] == b[5]
    assert yaw_rows(6).tolist() == [False] * 5 + [True]  # the yaw row stays sixth
    # What the rows ask of a foot's angular acceleration (J's angular rows the identity): a roll about the foot's
    # forward axis is free, a pitch about its lateral axis is held.
    Jw = np.zeros((6, 6))
    Jw[3:, 3:] = np.eye(3)
    Aw, _ = free_roll(Jw, np.zeros(6), forward)
    roll = np.r_[np.zeros(3), f]
    pitch = np.r_[np.zeros(3), R[1]]
    np.testing.assert_allclose(Aw @ roll, 0.0, atol=1e-12)
    assert abs(Aw[4] @ pitch - 1.0) < 1e-12
    assert J[3].any() and b[3] != 0.0  # (the input unchanged: new arrays)


def test_flat_contacts_frees_the_roll_of_the_marked_foot_only(scene) -> None:
    m, d, ctl, pts, frames, which, anchors, va = _pressed_at_home(scene)
    anchors = [(p + [0.01, -0.02, 0.0], r) for p, r in anchors]  # feedback on every row
    args = (m, d, ctl._feet, ctl._corners, anchors, va, pts, frames, which, 0.01, 100.0, 20.0)
    *_, all6 = flat_contacts(*args)
    *_, freed = flat_contacts(*args, roll_free=[ctl.feet.forward[0], None])
    assert all6 is not None and freed is not None and all6[0].shape == freed[0].shape == (12, len(va))
    body = ctl._feet[0]
    ref = free_roll(all6[0][:6], all6[1][:6], d.xmat[body].reshape(3, 3) @ ctl.feet.forward[0])
    np.testing.assert_allclose(freed[0][:6], ref[0])
    np.testing.assert_allclose(freed[1][:6], ref[1])
    assert not freed[0][3].any() and all6[0][3].any()  # the left foot's roll row: gone
    np.testing.assert_array_equal(freed[0][6:], all6[0][6:])  # the right foot's six: as they were
    np.testing.assert_array_equal(freed[1][6:], all6[1][6:])


def test_flat_roll_free_needs_flat_feet() -> None:
    with pytest.raises(ConfigError, match="flat_roll_free"):
        BalanceConfig(solver="qp", flat_roll_free=True)
    assert BalanceConfig(solver="qp", flat_feet=True, flat_roll_free=True).flat_roll_free
