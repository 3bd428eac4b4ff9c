"""The physics-rate balance controller (sim/balance_control.py, sim/contact_dynamics.py): the floating-base inverse
dynamics against MuJoCo's forward dynamics, the centre-of-mass feedback's direction, the harness decisions,
determinism and the configuration's errors."""

from __future__ import annotations


import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController, lean_offset
from socialaff_sim.sim.contact_dynamics import cone_edges, solve_contact_dynamics
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.external_force import ExternalForces
from socialaff_sim.sim.feedforward import StandingFeedforward
from socialaff_sim.sim.scene import Scene, pose_compliant
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.support_box import SupportBox

LAYOUT = get_layout("kinect_v2")

# A floating trunk on two legs of two hinges each (hip and knee pitch), without floor or contacts: the
# contact forces of the inverse dynamics are applied as external forces, and MuJoCo's forward dynamics
# must then give back the accelerations the inverse dynamics chose.
BIPED = """
<mujoco>
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <worldbody>
    <body name="trunk" pos="0 0 1.0">
      <freejoint/>
      <inertial pos="0.01 0 0.25" mass="20" diaginertia="0.8 0.7 0.3"/>
      <body name="lthigh" pos="0 0.1 0">
        <joint name="lhip" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="3" diaginertia="0.05 0.05 0.01"/>
        <body name="lfoot" pos="0 0 -0.45">
          <joint name="lknee" axis="0 1 0"/>
          <inertial pos="0 0 -0.25" mass="2" diaginertia="0.04 0.04 0.01"/>
        </body>
      </body>
      <body name="rthigh" pos="0 -0.1 0">
        <joint name="rhip" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="3" diaginertia="0.05 0.05 0.01"/>
        <body name="rfoot" pos="0 0 -0.45">
          <joint name="rknee" axis="0 1 0"/>
          <inertial pos="0 0 -0.25" mass="2" diaginertia="0.04 0.04 0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _biped(rng: np.random.Generator) -> tuple[mujoco.MjModel, mujoco.MjData]:
    m = mujoco.MjModel.from_xml_string(BIPED)
    d = mujoco.MjData(m)
    d.qpos[7:] = rng.uniform(-0.3, 0.3, size=4)
    d.qvel[:] = rng.normal(scale=0.3, size=m.nv)
    mujoco.mj_forward(m, d)
    return m, d


def _points(m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Four sole corners per foot, 0.45 m below each knee: points (8, 3), bodies (8,), Jacobians (8, 3, nv)."""
    pts, bodies, jac = [], [], []
    jp = np.zeros((3, m.nv))
    for name in ("lfoot", "rfoot"):
        b = m.body(name).id
        R = d.xmat[b].reshape(3, 3)
        for dx in (-0.05, 0.12):
            for dy in (-0.04, 0.04):
                p = d.xpos[b] + R @ np.array([dx, dy, -0.45])
                mujoco.mj_jac(m, d, jp, None, p, b)
                pts.append(p)
                bodies.append(b)
                jac.append(jp.copy())
    return np.array(pts), np.array(bodies), np.array(jac)


def _solve(m: mujoco.MjModel, d: mujoco.MjData, tasks: list, w_dynamics: float = 1e6):
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    pts, bodies, jac = _points(m, d)
    frames = np.tile(np.eye(3)[[2, 0, 1]], (len(pts), 1, 1))  # rows: normal +z, tangents x and y
    unact = np.zeros(m.nv, dtype=bool)
    unact[:6] = True
    res = solve_contact_dynamics(M, d.qfrc_bias.copy(), unact, jac, cone_edges(frames, 0.7), tasks,
                                 mass=float(m.body_mass.sum()), w_dynamics=w_dynamics, w_force=1e-3)
    return res, pts, bodies


def test_torques_and_contact_forces_reproduce_the_chosen_accelerations_in_forward_dynamics(rng) -> None:
    m, d = _biped(rng)
    want = rng.normal(scale=2.0, size=m.nv - 6)
    tasks = [(np.eye(m.nv)[6:], want, 1.0)]
    res, pts, bodies = _solve(m, d, tasks)
    # Independent: MuJoCo's forward dynamics with the torques on the hinges and the forces at the points.
    f = mujoco.MjData(m)
    f.qpos[:], f.qvel[:] = d.qpos, d.qvel
    f.qfrc_applied[6:] = res.tau[6:]
    mujoco.mj_forward(m, f)
    for p, b, force in zip(pts, bodies, res.forces, strict=True):
        mujoco.mj_applyFT(m, f, force, np.zeros(3), p, int(b), f.qfrc_applied)
    mujoco.mj_forward(m, f)
    np.testing.assert_allclose(f.qacc, res.qacc, atol=1e-4 * max(1.0, np.abs(res.qacc).max()))
    # The root takes no torque: the residual of the unactuated rows is negligible next to the weight.
    assert np.abs(res.tau[:6]).max() <= 1e-3 * m.body_mass.sum() * 9.81


def test_contact_forces_of_a_still_stance_carry_the_weight_inside_the_cones(rng) -> None:
    m = mujoco.MjModel.from_xml_string(BIPED)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    # Standing still (every acceleration zero): the forces carry the weight, push, and stay in their cones.
    tasks = [(np.eye(m.nv), np.zeros(m.nv), 1.0)]
    res, _, _ = _solve(m, d, tasks)
    weight = m.body_mass.sum() * 9.81
    np.testing.assert_allclose(res.forces.sum(axis=0), [0.0, 0.0, weight], atol=1e-3 * weight)
    assert (res.forces[:, 2] >= -1e-9).all()
    assert (np.abs(res.forces[:, :2]).max(axis=1) <= 0.7 * res.forces[:, 2] + 1e-9).all()
    # The moment of the weight about the centre of mass is balanced: the centre of pressure is under it.
    cop = (res.forces[:, 2, None] * _points(m, d)[0]).sum(axis=0) / res.forces[:, 2].sum()
    mujoco.mj_comPos(m, d)
    np.testing.assert_allclose(cop[:2], d.subtree_com[1, :2], atol=1e-3)


def test_cone_edges_are_unit_and_at_the_friction_angle() -> None:
    e = cone_edges(np.eye(3)[[2, 0, 1]][None], 0.5)[0]  # normal +z
    np.testing.assert_allclose(np.linalg.norm(e, axis=0), 1.0)
    np.testing.assert_allclose(np.abs(e[:2]).max(axis=0) / e[2], 0.5)


# -- Stubby in physics ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


def standing_far(scene: Scene, config: BalanceConfig) -> tuple[mujoco.MjData, np.ndarray, BalanceController, np.ndarray]:
    """Stubby at home on its feet, the person's bodies far away, under a fresh controller: (data, the home
    qpos, the controller, the servos' commands at home with the standing feed-forward)."""
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    d.qpos[scene.robot_qadr] = q
    far = np.array([10.0, 10.0, 1.0]) + np.arange(len(scene.human_mocap))[:, None] * [0.0, 0.3, 0.0]
    d.mocap_pos[scene.human_mocap] = far
    pose_compliant(scene, d, far, np.array(d.mocap_quat[scene.human_mocap]))
    d.mocap_pos[scene.anchor_mocap], d.mocap_quat[scene.anchor_mocap] = q[:3], q[3:7]
    mujoco.mj_forward(m, d)
    ctl = BalanceController(scene, config)
    ctrl0 = scene.ctrl_for(d.qpos.copy()) + StandingFeedforward(scene).ctrl_offset(d.qpos.copy())
    return d, q, ctl, ctrl0


def _stand(scene: Scene, config: BalanceConfig, seconds: float, push: tuple[float, float, float] = (0.0, 0.0, 0.0),
           planted: tuple[bool, bool] = (True, True)) -> tuple[BalanceController, mujoco.MjData, list[tuple[np.ndarray, int]]]:
    """Stubby at home on its feet under the controller, the person far away; ``push``: (start s, end s, force N
    forward on the torso's centre of mass). Returns the controller, the data and, at the start and every 0.1 s, the centre of mass and
    whether the harness weld is on."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
    trace = [(np.array(d.subtree_com[scene.root_body]), 1)]
    for k in range(int(round(seconds / m.opt.timestep))):
        if k % 25 == 0:
            ctl.begin_frame(q, planted)
        t = k * m.opt.timestep
        d.xfrc_applied[ctl._torso, 0] = push[2] if push[0] <= t < push[1] else 0.0
        d.ctrl[scene.act_ids] = ctrl0  # the servos' commands, which the controller replaces while it drives
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if k % 25 == 24:
            trace.append((np.array(d.subtree_com[scene.root_body]), int(d.eq_active[weld])))
    return ctl, d, trace


def _feet_middle(scene: Scene, d: mujoco.MjData) -> np.ndarray:
    """(2,) the middle of Stubby's two box feet on the floor, from the geoms themselves."""
    m = scene.model
    feet = [g for g in range(m.ngeom) if "foot" in (m.geom(g).name or "") and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
            and scene.robot_geom[g]]
    assert len(feet) == 2
    return d.geom_xpos[feet, :2].mean(axis=0)


def test_centre_of_mass_feedback_brings_the_centre_of_mass_over_the_middle_of_the_feet(scene: Scene) -> None:
    # At home Stubby's centre of mass is 2 cm behind the middle of its feet (short heels): held at the middle, it
    # must move forward and stay there. With the feedback's sign inverted it runs backward off its heels.
    ctl, d, trace = _stand(scene, BalanceConfig(com_reference="middle", support_margin=0.0), 2.5)
    mid = _feet_middle(scene, d)
    start = np.linalg.norm(trace[0][0][:2] - mid)
    assert start >= 0.015
    # It comes most of the way (the joints' feedback toward the home posture holds a little back) and stays.
    assert np.linalg.norm(trace[-1][0][:2] - mid) <= 0.5 * start
    assert abs(np.linalg.norm(trace[-1][0][:2] - mid) - np.linalg.norm(trace[-5][0][:2] - mid)) <= 0.002
    assert trace[-1][0][0] - trace[0][0][0] >= 0.008  # forward, toward the middle
    assert ctl.harness.catches == 0 and ctl.harness.released and trace[-1][1] == 0
    assert ctl.attitude.tilt(d) <= 2.0


def com_moved(scene: Scene, config: BalanceConfig, offset: np.ndarray | float, seconds: float = 2.0) -> tuple[np.ndarray, BalanceController]:
    """Stubby standing at home under the controller while the plan is its home pose moved by ``offset`` ((2,) m, or a
    float: m along x, forward), feet and all: the centre of mass's horizontal displacement (m) after ``seconds``, and
    the controller."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    plan = q.copy()
    plan[:2] += np.array([offset, 0.0]) if np.isscalar(offset) else np.asarray(offset)
    com0 = np.array(d.subtree_com[scene.root_body, :2])
    for k in range(int(round(seconds / m.opt.timestep))):
        if k % 25 == 0:
            ctl.begin_frame(plan, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
    return np.array(d.subtree_com[scene.root_body, :2]) - com0, ctl


@pytest.mark.parametrize("dx", [0.03, -0.03])
def test_the_plan_reference_carries_the_plans_offset_onto_the_physical_feet(scene: Scene, dx: float) -> None:
    # The plan stands 3 cm ahead of (behind) the physical robot, feet and all. ``plan`` carries the plan's offset from
    # its feet onto the physical feet: nothing to do, the centre of mass stays (held where the plan has it in the
    # world, it would follow the plan along dx: the removed ``world`` reference, docs/design.md §5).
    plan, ctl = com_moved(scene, BalanceConfig(), dx)
    assert np.linalg.norm(plan) <= 0.002
    assert ctl.harness.catches == 0 and ctl.harness.released


def test_each_reference_against_mujocos_centre_of_mass(scene: Scene) -> None:
    # The plan: home moved 0.3 m forward and 0.1 m to the side, its left leg bent; the physical robot at home.
    # ``plan`` = the physical feet's middle + the plan's centre of mass minus its feet's middle, from MuJoCo's own
    # subtree centre of mass of the plan's pose; ``middle`` = the support box's middle, whatever the plan.
    m = scene.model
    d, q, ctl, _ = standing_far(scene, BalanceConfig())
    plan = q.copy()
    plan[:2] += [0.3, 0.1]
    plan[7 + 2] += 0.4
    p = mujoco.MjData(m)
    p.qpos[scene.robot_qadr] = plan
    mujoco.mj_forward(m, p)
    com_plan = p.subtree_com[scene.root_body, :2]
    feet = ctl._feet
    ctl.begin_frame(plan, (True, True))
    want = d.xpos[feet, :2].mean(axis=0) + com_plan - p.xpos[feet, :2].mean(axis=0)
    assert np.allclose(ctl.com.reference(d, None), want, atol=1e-9)  # type: ignore[arg-type]
    assert np.linalg.norm(want - com_plan) >= 0.25  # not the plan's own centre of mass: they differ by its shift
    box = SupportBox(np.array([[0.1, -0.2], [0.3, 0.0], [0.2, -0.05]]), np.array([0.6, 0.8]))
    ctl_m = BalanceController(scene, BalanceConfig(com_reference="middle"))
    ctl_m.begin_frame(plan, (True, True))
    local = np.array([[0.1, -0.2], [0.3, 0.0], [0.2, -0.05]]) @ box.R.T  # brute force: the box in its own axes
    assert np.allclose(ctl_m.com.reference(d, box), 0.5 * (local.min(axis=0) + local.max(axis=0)) @ box.R, atol=1e-12)


def test_a_pushed_robot_returns_to_its_stance_on_its_own_feet(scene: Scene) -> None:
    ctl, d, trace = _stand(scene, BalanceConfig(), 3.0, push=(0.5, 0.7, 80.0))
    com0 = trace[4][0][:2]  # standing, before the push
    dev = [float(np.linalg.norm(c[:2] - com0)) for c, _ in trace]
    assert max(dev) >= 0.015  # the push (16 N·s at the chest) moved it
    assert dev[-1] <= 0.005  # and it came back
    assert ctl.harness.catches == 0 and all(on == 0 for _, on in trace[2:])  # without the harness
    assert ctl.attitude.tilt(d) <= 2.0


def test_harness_lets_go_of_a_steady_robot_after_the_delay_and_catches_a_falling_one(scene: Scene) -> None:
    cfg = BalanceConfig(release_delay=0.15)
    ctl, _, trace = _stand(scene, cfg, 0.5)
    assert trace[1][1] == 1 and all(on == 0 for _, on in trace[3:])  # on until 0.15 s, off after
    assert ctl.harness.released_steps == ctl.active_steps > 0
    # A shove that carries the capture point off the feet: caught.
    ctl, _, trace = _stand(scene, cfg, 1.5, push=(0.5, 0.8, 400.0))
    assert ctl.harness.catches >= 1 and any(on == 1 for _, on in trace[7:])


def test_no_release_without_both_feet_planted_or_when_switched_off(scene: Scene) -> None:
    for planted, cfg in (((True, False), BalanceConfig()), ((True, True), BalanceConfig(release=False))):
        ctl, _, trace = _stand(scene, cfg, 0.4, planted=planted)
        assert ctl.harness.released_steps == 0 and ctl.active_steps == 0
        assert all(on == 1 for _, on in trace)
    ctl, _, trace = _stand(scene, BalanceConfig(release=False, drive_harnessed=True), 0.4)
    assert ctl.harness.released_steps == 0 and ctl.active_steps > 0 and all(on == 1 for _, on in trace)


def _episode(ours, config: SimConfig) -> list:
    data = generate_dataset(seed=0)
    inter = min(data.of_label("shake_hands"), key=lambda i: i.n_frames)
    sim = Simulator(ours, "shake_hands", config)
    run_episode(sim, GroundTruthSource(), inter)
    return sim.results


def test_an_episode_under_the_controller_is_deterministic(ours) -> None:
    cfg = SimConfig.harness(balance=BalanceConfig(), stance=StanceConfig(release=False))
    a, b = _episode(ours, cfg), _episode(ours, cfg)
    assert [r.support for r in a] == [r.support for r in b]
    assert [r.subgoals for r in a] == [r.subgoals for r in b]
    assert any(r.support.outside_peak == 0.0 for r in a)  # the harness did let go in some frames


@pytest.mark.parametrize("kw", [{"com_bandwidth": 0.0}, {"joint_bandwidth": -1.0}, {"com_reference": "hips"},
                                {"com_reference": "world"}, {"com_reference": "approach"},  # removed (design.md §5)
                                {"release_tilt": 20.0, "catch_tilt": 10.0}, {"friction": 0.0}, {"w_force": 0.0},
                                {"support_margin": -0.01}])
def test_balance_config_rejects_bad_values(kw) -> None:
    with pytest.raises(ConfigError, match="BalanceConfig"):
        BalanceConfig(**kw)


def test_sim_config_rejects_two_controllers_of_the_harness_and_a_controller_without_foot_lock() -> None:
    with pytest.raises(ConfigError, match="stance.release"):
        SimConfig(balance=BalanceConfig(), stance=StanceConfig())
    with pytest.raises(ConfigError, match="stance.release"):
        SimConfig.standing(stance=StanceConfig())  # the standing mode's balance controller switches the harness
    with pytest.raises(ConfigError, match="foot_lock"):
        SimConfig(balance=BalanceConfig(), foot_lock=None)
    assert SimConfig(balance=BalanceConfig(), stance=StanceConfig(release=False)).balance is not None
    assert SimConfig.harness(stance=StanceConfig()).balance is None
    assert SimConfig().balance is None  # off by default (docs/design.md §5: the rule for the standing mode failed)


def test_external_contact_forces_are_the_constraint_forces_they_come_from(scene: Scene) -> None:
    # Standing released on its feet, the floor's contacts are the only constraint on the robot: counted as
    # external forces, their generalised force must be MuJoCo's own qfrc_constraint on the robot's coordinates.
    ctl, d, _ = _stand(scene, BalanceConfig(), 0.4)
    assert ctl.harness.released
    gen, pts, forces = ExternalForces(scene, exclude_floor=False).measure(scene.model, d)
    np.testing.assert_allclose(gen, d.qfrc_constraint[scene.robot_vadr], atol=1e-6 * ctl.mass * 9.81)
    np.testing.assert_allclose(forces.sum(axis=0)[2], ctl.mass * 9.81, rtol=0.02)  # the feet carry the weight
    gen, pts, _ = ExternalForces(scene).measure(scene.model, d)  # and nothing else touches the robot
    assert len(pts) == 0 and not gen.any()


def test_lean_offset_leans_against_a_pull() -> None:
    # A 100 N pull forward at 1 m above the foot's point: the centre of mass goes back by F·h / W.
    point = np.array([0.3, 0.2, 0.0])
    r = point + [0.4, 0.0, 1.0]
    f = np.array([100.0, 0.0, 0.0])
    np.testing.assert_allclose(lean_offset(np.cross(r, f), f, point, 500.0), [-0.2, 0.0], atol=1e-12)
    f = np.array([0.0, -50.0, 0.0])  # sideways to the right: lean left
    np.testing.assert_allclose(lean_offset(np.cross(r, f), f, point, 500.0), [0.0, 0.1], atol=1e-12)
    f = np.array([0.0, 0.0, -100.0])  # a load hanging 0.4 m ahead: lean back by 0.4 · 100 / 500
    np.testing.assert_allclose(lean_offset(np.cross(r, f), f, point, 500.0), [-0.08, 0.0], atol=1e-12)
