"""Physics scoring of sub-goals and failures, and the ground-truth replay on synthetic data."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from conftest import shared_robot
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.data.interaction import Interaction
from socialaff_sim.sim.carry import fit_flight, plan_carry
from socialaff_sim.sim.human import human_body
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.scene import ObjectSpec, Scene, build_scene, pose_compliant
from socialaff_sim.sim.scoring import FORCE_TIME_CONSTANT, SubgoalResult, SubgoalScorer
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stage import contact_exemptions
from socialaff_sim.sim.tasks import ROBOT_GROUPS, FailureSpec, SubgoalSpec, load_task

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=2))


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(load_robot("ours"), LAYOUT, None)


def task_with(subgoals: list[SubgoalSpec], failures: list[FailureSpec]):
    return dataclasses.replace(load_task("shake_hands"), subgoals=tuple(subgoals), failures=tuple(failures))


def human_away(scene: Scene, d: mujoco.MjData) -> np.ndarray:
    n = len(scene.human_mocap)
    pos = np.array([10.0, 10.0, 1.0]) + np.arange(n)[:, None] * [0.0, 0.3, 0.0]
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    d.mocap_pos[scene.human_mocap] = pos
    d.mocap_quat[scene.human_mocap] = quat
    pose_compliant(scene, d, pos, quat)
    return pos


def robot_home_human_away(scene: Scene) -> tuple[mujoco.MjData, np.ndarray]:
    """Fresh data with the robot at home and the person's bones parked far away (forward kinematics done)."""
    d = mujoco.MjData(scene.model)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    pos = human_away(scene, d)
    mujoco.mj_forward(scene.model, d)
    return d, pos


def test_contact_time_accumulates_to_min_duration(scene: Scene) -> None:
    m = scene.model
    d, pos = robot_home_human_away(scene)
    palm = np.flatnonzero(scene.hand_geom[1])[0]
    task = task_with([SubgoalSpec("touch", "contact", "right_hand", "hands", 0.1, ())], [])
    scorer = SubgoalScorer(scene, task)
    dt = 0.004
    t = 0.0
    steps_touching = 0
    for k in range(60):
        touching = 10 <= k < 45
        pos[scene.n_bones + 1] = d.geom_xpos[palm] + ((0.06 if touching else 1.0), 0.0, 0.0)
        d.mocap_pos[scene.human_mocap] = pos
        pose_compliant(scene, d, pos, np.array(d.mocap_quat[scene.human_mocap]))
        mujoco.mj_forward(m, d)  # contacts of this placement, no dynamics needed
        t += dt
        scorer.update(d, dt, t, None)
        steps_touching += touching
    res = scorer.subgoals[0]
    np.testing.assert_allclose(res.contact_time, steps_touching * dt, atol=1e-12)
    assert res.success
    # Met on the step where 0.1 s of contact had accumulated: the 25th touching step.
    np.testing.assert_allclose(res.time, (10 + 25) * dt, atol=1e-9)


def test_subevent_window_and_other_hand(scene: Scene) -> None:
    m = scene.model
    d, pos = robot_home_human_away(scene)
    palm = np.flatnonzero(scene.hand_geom[1])[0]
    pos[scene.n_bones + 1] = d.geom_xpos[palm] + (0.06, 0.0, 0.0)
    d.mocap_pos[scene.human_mocap] = pos
    pose_compliant(scene, d, pos, np.array(d.mocap_quat[scene.human_mocap]))
    mujoco.mj_forward(m, d)
    task = task_with([
        SubgoalSpec("windowed", "contact", "right_hand", "hands", 0.0, ("shake",)),
        SubgoalSpec("left_only", "contact", "left_hand", "hands", 0.0, ()),
    ], [])
    scorer = SubgoalScorer(scene, task)
    scorer.update(d, 0.01, 0.01, "reach")
    assert not scorer.subgoals[0].success and not scorer.subgoals[1].success
    scorer.update(d, 0.01, 0.02, "shake")
    assert scorer.subgoals[0].success and not scorer.subgoals[1].success


def test_self_collision_threshold(scene: Scene) -> None:
    m = scene.model
    d = mujoco.MjData(m)
    human_away(scene, d)
    q = scene.home_qpos.copy()
    task = task_with([SubgoalSpec("x", "contact", "hands", "hands", 1.0, ())], [FailureSpec("self_collision", 0.02)])
    names = list(scene.robot_joint_names)
    # Bend the left forearm across the chest and roll the arm inward until it sinks into the torso.
    depths = []
    q[6 + names.index("robot/left_shoulder_yaw")] = -0.8
    q[6 + names.index("robot/left_elbow")] = -1.5
    for roll in np.linspace(0.3, -0.3, 13):
        q[6 + names.index("robot/left_shoulder_roll")] = roll
        d.qpos[scene.robot_qadr] = q
        mujoco.mj_forward(m, d)
        robot = scene.robot_geom
        pen = [-d.contact.dist[i] for i in range(d.ncon) if robot[d.contact.geom1[i]] and robot[d.contact.geom2[i]]]
        depths.append(max(pen, default=0.0))
        scorer = SubgoalScorer(scene, task)
        scorer.update(d, 0.004, 0.004, None)
        assert scorer.failed == (depths[-1] > 0.02)
        np.testing.assert_allclose(scorer.failures[0].worst, depths[-1], atol=1e-12)
    assert min(depths) < 0.02 < max(depths)  # the sweep covers both outcomes


def test_force_on_human_is_smoothed_contact_force(scene: Scene) -> None:
    m = scene.model
    d, pos = robot_home_human_away(scene)
    palm = np.flatnonzero(scene.hand_geom[0])[0]
    task = task_with([SubgoalSpec("x", "contact", "hands", "hands", 1.0, ())], [FailureSpec("contact_force", 1e9)])
    scorer = SubgoalScorer(scene, task)
    dt, ema, peak, f6 = 0.004, 0.0, 0.0, np.zeros(6)
    human = set(scene.human_geom_ids.tolist())
    start = d.geom_xpos[palm] + (0.08, 0.0, 0.0)
    pos[scene.n_bones] = start
    pose_compliant(scene, d, pos, np.array(d.mocap_quat[scene.human_mocap]))
    d.ctrl[scene.act_ids] = scene.ctrl_for(d.qpos)
    for k in range(40):
        pos[scene.n_bones] = start - (0.003 * k, 0.0, 0.0)  # the left hand sphere pressed ever deeper
        d.mocap_pos[scene.human_mocap] = pos
        mujoco.mj_step(m, d)
        scorer.update(d, dt, (k + 1) * dt, None)
        total = 0.0
        for i in range(d.ncon):
            g1, g2 = d.contact.geom1[i], d.contact.geom2[i]
            if d.contact.dist[i] <= 0 and ((g1 in human and scene.robot_geom[g2]) or (g2 in human and scene.robot_geom[g1])):
                mujoco.mj_contactForce(m, d, i, f6)
                total += f6[0]
        ema += dt / FORCE_TIME_CONSTANT * (total - ema)
        peak = max(peak, total)
    assert peak > 1.0
    np.testing.assert_allclose(scorer.max_force_on_human, peak, rtol=1e-9)
    np.testing.assert_allclose(scorer.force_filtered, ema, rtol=1e-9)


@pytest.fixture(scope="module")
def cup_scene() -> Scene:
    return build_scene(load_robot("ours"), LAYOUT, ObjectSpec("cylinder", (0.045, 0.06), 0.25))


def test_a_gripped_object_counts_as_held_without_touching(cup_scene: Scene) -> None:
    m = cup_scene.model
    task = dataclasses.replace(load_task("hand_over"), failures=())
    dt, steps = 0.004, 100  # 0.4 s, more than the 0.3 s asked for

    def run(grip: bool, release: bool) -> bool:
        d = mujoco.MjData(m)
        d.qpos[cup_scene.robot_qadr] = cup_scene.home_qpos
        human_away(cup_scene, d)
        qa = cup_scene.object_qadr
        d.qpos[qa:qa + 3] = (0.5, 0.0, 1.0)  # in the air, touching nothing
        d.eq_active[cup_scene.grip_eq[1]] = grip
        mujoco.mj_forward(m, d)
        scorer = SubgoalScorer(cup_scene, task)
        if release:
            scorer.mark_release(0.0)
        for k in range(steps):
            scorer.update(d, dt, (k + 1) * dt, None)
        res = scorer.subgoals[0]
        # judged only at the end: before finish() the caption must not claim "not achieved"
        assert res.pending and res.state_text().endswith("| judged at the end") and not res.success
        scorer.finish(steps * dt)
        assert not res.pending
        assert res.state_text().endswith(f"| achieved at {res.time:.2f} s" if res.success else "| not achieved")
        scorer.reset()
        assert scorer.subgoals[0].pending
        return res.success

    assert run(grip=True, release=True)
    assert not run(grip=False, release=True)  # neither touched nor gripped
    assert not run(grip=True, release=False)  # the person still holds it


def test_quiet_steps_score_like_full_ones(data) -> None:
    """The shortcut for steps without a relevant contact changes nothing: same run, shortcut disabled."""
    inter = data.of_label("hand_over")[0]
    results = []
    for shortcut in (True, False):
        sim = Simulator("ours", "hand_over", SimConfig.harness())
        sim.reset(inter)
        if not shortcut:
            sim.scorer._interesting[:] = True
        src = GroundTruthSource()
        src.reset(inter)
        sim.settle(sim.retarget(src.targets(0).keys, frame=0))
        while not sim.done:
            f = src.targets(sim.frame + 1)
            sim.step(sim.retarget(f.keys, frame=sim.frame + 1), subevent=f.subevent)
        sc = sim.scorer
        results.append(([(r.success, r.time, r.contact_time) for r in sc.subgoals],
                        [(f.triggered, f.worst) for f in sc.failures], sc.max_force_filtered, sim.data.qpos.copy()))
    assert results[0][:3] == results[1][:3]
    np.testing.assert_array_equal(results[0][3], results[1][3])


def test_the_carrying_hand_is_the_nearer_one() -> None:
    T = 20
    joints = np.zeros((T, 2, LAYOUT.n_joints, 3))
    joints[..., 2] = 1.0
    joints[:, 1, :, 0] = 1.2
    n = LAYOUT.joint_names
    t = np.arange(T)
    # The right hand moves about with the object 6 cm from it; the left hangs perfectly still, far away.
    joints[:, 0, n.index("right_hand")] = np.stack([0.3 + 0.02 * np.sin(t), -0.2 + 0.02 * np.cos(t), 1.0 + 0.01 * t], axis=1)
    joints[:, 0, n.index("left_hand")] = (0.0, 0.3, 0.7)
    obj = joints[:, 0, n.index("right_hand")] + (0.06, 0.0, 0.0)
    inter = Interaction("hand_over", 10.0, joints, n, ("a", "b"), object=obj)
    plan = plan_carry(inter, np.zeros(3), load_task("hand_over").object, human_body(LAYOUT).hand_joints)
    assert plan.hand == "right_hand" and plan.release_frame == T  # never let go


def test_flight_fit_recovers_a_throw(rng: np.random.Generator) -> None:
    p0, v0, fps = np.array([0.1, 0.2, 1.0]), np.array([3.0, -0.5, 2.5]), 12.0
    t = np.arange(5) / fps
    track = p0 + v0 * t[:, None] + 0.5 * np.array([0, 0, -9.81]) * t[:, None] ** 2
    p, v = fit_flight(track, fps)
    np.testing.assert_allclose(p, p0, atol=1e-12)
    np.testing.assert_allclose(v, v0, atol=1e-10)
    noisy, vn = fit_flight(track + rng.normal(0, 0.005, track.shape), fps)
    assert np.linalg.norm(vn - v0) < 0.3


def replay(inter, robot: str = "ours", config: SimConfig | None = None) -> dict:
    sim = Simulator(robot, inter.label, config)
    return run_episode(sim, GroundTruthSource(), inter)


def test_ground_truth_hand_over_keeps_the_cup(data) -> None:
    metrics = replay(data.of_label("hand_over")[0])
    assert metrics["subgoals"][0]["success"] and not metrics["success"] is False
    assert metrics["object_released_at"] is not None
    # Without grasping the same motion does not end with the cup in hand.
    dropped = replay(data.of_label("hand_over")[0], config=SimConfig(grip=False))
    assert not dropped["subgoals"][0]["success"] and not dropped["success"]


def test_ground_truth_handshake_and_catch(data) -> None:
    shake = replay(data.of_label("shake_hands")[0])
    assert shake["success"], shake["subgoals"]
    catch = replay(data.of_label("throw_catch")[0])
    assert catch["subgoals"][0]["success"], catch["failures"]


@pytest.mark.slow
@pytest.mark.parametrize(("robot", "floor"), [("ours", 0.9), ("cmu", 0.75)])
def test_ground_truth_success_rate(robot: str, floor: float) -> None:
    # Regression floors below the measured levels (scripts/bench_sim.py, all 120 synthetic instances: ours 98 %,
    # cmu 89 %). The misses left are physical: a high five's brief contact missed by the servos' lag, the CMU
    # humanoid's short arms pulling a rising person, a ball slipping between two hands.
    dataset = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=4))
    results = {label: [replay(i, robot)["success"] for i in dataset.of_label(label)] for label in dataset.labels}
    rate = np.mean([s for v in results.values() for s in v])
    print(robot, {k: np.mean(v) for k, v in results.items()}, rate)
    assert rate >= floor


def test_real_handover_recording_replays() -> None:
    from conftest import shared_path

    from socialaff_sim.data.handover import load_handover

    inter = load_handover(shared_path("handover_h2h", "motion_normal_1.pkl"))[0]
    sim = Simulator("ours", "hand_over", SimConfig.harness())
    metrics = run_episode(sim, GroundTruthSource(), inter)
    assert sim.carry is not None and 0 < sim.carry.release_frame < inter.n_frames  # given, then taken
    assert metrics["frames"] == inter.n_frames and metrics["object_released_at"] is not None
    assert metrics["ik_error_reachable_within_2cm"] >= 0.9
    print(metrics["subgoals"], [f for f in metrics["failures"] if f["triggered"]])


def _hand_gap_by_hand(m: mujoco.MjModel, d: mujoco.MjData, hand_geoms: np.ndarray, centre: np.ndarray, radius: float) -> float:
    """Independent reference: sphere (centre, radius) to the nearest box or capsule of the hand, analytically."""
    best = np.inf
    for g in hand_geoms:
        R = d.geom_xmat[g].reshape(3, 3)
        local = R.T @ (centre - d.geom_xpos[g])
        size = m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            outside = np.maximum(np.abs(local) - size, 0.0)
            dist = np.linalg.norm(outside) if outside.any() else -np.min(size - np.abs(local))
        else:  # capsule along local z
            z = np.clip(local[2], -size[1], size[1])
            dist = np.linalg.norm(local - np.array([0.0, 0.0, z])) - size[0]
        best = min(best, dist - radius)
    return float(best)


def test_contact_now_and_achieved_are_separate_and_a_lost_contact_shows(scene: Scene) -> None:
    m = scene.model
    d, pos = robot_home_human_away(scene)
    hand = np.flatnonzero(scene.hand_geom[1])
    palm = hand[0]
    sphere = scene.human_geom_ids[scene.n_bones + 1]
    radius = float(m.geom_size[sphere, 0])
    normal = d.geom_xmat[palm].reshape(3, 3)[:, 0]  # the palm box's thinnest axis
    task = task_with([SubgoalSpec("clasp", "contact", "right_hand", "hands", 0.1, ())], [])
    scorer = SubgoalScorer(scene, task)
    dt, t = 0.004, 0.0
    # Far (1.5 m), touching (pressed 1 cm in) for 35 steps, then lost: 10 cm clear of the palm's face.
    phases = [(10, 1.5 + 0.025 + radius), (35, 0.025 + radius - 0.01), (15, 0.025 + radius + 0.10)]
    seen = []
    for n, offset in phases:
        for _ in range(n):
            pos[scene.n_bones + 1] = d.geom_xpos[palm] + offset * normal
            d.mocap_pos[scene.human_mocap] = pos
            pose_compliant(scene, d, pos, np.array(d.mocap_quat[scene.human_mocap]))
            mujoco.mj_forward(m, d)
            t += dt
            scorer.update(d, dt, t, None)
            scorer.measure_gaps(d)
            res = scorer.subgoals[0]
            seen.append((res.current, res.achieved, res.gap))
        ref = _hand_gap_by_hand(m, d, hand, d.geom_xpos[sphere], radius)
        if res.gap is not None:
            np.testing.assert_allclose(res.gap, ref, atol=1e-6)
    res = scorer.subgoals[0]
    far, touch, lost = seen[:10], seen[10:45], seen[45:]
    assert not any(c or a for c, a, _ in far) and far[-1][2] is None  # 1 m away: beyond the gap's range
    assert all(c for c, _, _ in touch) and touch[-1][1] and not touch[23][1]  # met on the 25th touching step
    assert all(a and not c for c, a, _ in lost)  # achieved stays, the contact now does not
    assert lost[-1][2] > 0.03  # (the thumb is nearer than the palm's face: checked against the reference above)
    assert not res.pending  # a contact sub-goal is judged as it happens
    assert res.state_text() == f"clasp: now apart ({100 * lost[-1][2]:.1f} cm) | achieved at {res.time:.2f} s"
    assert res.time == pytest.approx(35 * dt)
    # Touched first on the 11th step and last on the 45th (the outcome code's "contact lost" reads these).
    assert res.first_touch == pytest.approx(11 * dt) and res.last_touch == pytest.approx(45 * dt)


def _raise_right_arm(scene: Scene, d: mujoco.MjData) -> None:
    """Turn the right arm's root joints (kinematics only) to the angle that lifts the right palm highest."""
    m = scene.model
    b = int(scene.limb_body_ids[1])
    palm = np.flatnonzero(scene.hand_geom[1])[0]
    best = (-np.inf, None, 0.0)
    for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])):
        q = int(m.jnt_qposadr[j])
        home = float(d.qpos[q])
        for angle in np.linspace(-np.pi, np.pi, 25):
            d.qpos[q] = home + angle
            mujoco.mj_kinematics(m, d)
            if d.geom_xpos[palm, 2] > best[0]:
                best = (float(d.geom_xpos[palm, 2]), q, home + angle)
        d.qpos[q] = home
    assert best[1] is not None
    d.qpos[best[1]] = best[2]


_MJCF = {"unitree_h1": ("unitree_h1", "h1.xml"), "unitree_g1": ("unitree_g1", "g1_29dof.xml")}


@pytest.mark.parametrize(("gap", "text"), [(0.0004, "now apart (< 1 mm)"), (-0.002, "now apart (< 1 mm)"),
                                           (0.001, "now apart (0.1 cm)"), (0.0234, "now apart (2.3 cm)")])
def test_a_gap_under_a_millimetre_does_not_read_as_zero(gap: float, text: str) -> None:
    # "0.0 cm" beside "apart" reads as a touch the contact test did not see; a sheet says "< 1 mm" instead.
    res = SubgoalResult(name="slap", kind="contact", gap=gap)
    assert res.state_text() == f"slap: {text} | not achieved"
    assert SubgoalResult(name="slap", kind="contact", gap=gap, current=True).state_text().startswith("slap: now touching")


@pytest.mark.parametrize("robot", ["ours", "cmu", "unitree_h1", "unitree_g1"])
def test_a_high_five_counts_only_at_or_above_the_shoulders(robot: str) -> None:
    spec = load_robot(robot, mjcf=shared_robot(*_MJCF[robot])) if robot in _MJCF else load_robot(robot)
    scene = build_scene(spec, LAYOUT, None)
    m = scene.model
    # Independent reference: the shoulder bodies by the robot file's names, their xpos straight from MuJoCo.
    shoulder_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"robot/{f.name}") if f.kind == "body" else
                    int(m.site_bodyid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"robot/{f.name}")])
                    for f in spec.limb_roots[:2]]
    assert min(shoulder_ids) >= 0
    palm = np.flatnonzero(scene.hand_geom[1])[0]
    sphere = scene.human_geom_ids[scene.n_bones + 1]
    high = SubgoalSpec("meet", "contact", "right_hand", "hands", 0.0, (), above="robot_shoulders")
    anywhere = SubgoalSpec("any", "contact", "right_hand", "hands", 0.0, ())
    outcomes = {}
    for raised in (False, True):
        d, pos = robot_home_human_away(scene)
        if raised:
            _raise_right_arm(scene, d)
        mujoco.mj_forward(m, d)
        # The person's hand sphere pressed 1 cm into the robot's hand geom from in front (bisection along +x from
        # the geom's centre: a sphere buried in a mesh's middle reads no contact).
        centre = np.array(d.geom_xpos[palm])

        def place(offset: float) -> float:
            pos[scene.n_bones + 1] = centre + (offset, 0.0, 0.0)
            d.mocap_pos[scene.human_mocap] = pos
            pose_compliant(scene, d, pos, np.array(d.mocap_quat[scene.human_mocap]))
            mujoco.mj_forward(m, d)
            return float(mujoco.mj_geomDistance(m, d, int(palm), int(sphere), 1.0, None))

        lo, hi = 0.0, 0.6
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if place(mid) < -0.01 else (lo, mid)
        place(lo)
        # Reference: the palm–hand-sphere contacts and the shoulders' mean height, read from MuJoCo directly.
        shoulder_z = float(np.mean([d.xpos[i, 2] for i in shoulder_ids]))
        hand = set(np.flatnonzero(scene.hand_geom[1]).tolist())
        zs = [float(d.contact.pos[i, 2]) for i in range(d.ncon)
              if d.contact.dist[i] <= 0 and {int(d.contact.geom[i, 0]), int(d.contact.geom[i, 1])} & hand
              and sphere in (int(d.contact.geom[i, 0]), int(d.contact.geom[i, 1]))]
        assert zs, "the hand sphere must touch the palm"
        assert (min(zs) >= shoulder_z) if raised else (max(zs) < shoulder_z - 0.1)
        scorer = SubgoalScorer(scene, task_with([high, anywhere], []))
        scorer.update(d, 0.01, 0.01, None)
        meet, any_ = scorer.subgoals
        assert any_.current and any_.success  # without the condition the touch counts at either height
        outcomes[raised] = (meet.current, meet.success, meet.contact_time, meet.low)
        if not raised:
            assert meet.state_text() == "meet: now touching below the robot's shoulders | not achieved"
    assert outcomes[False] == (False, False, 0.0, True)  # a waist-height touch is no high five
    assert outcomes[True] == (True, True, 0.01, False)  # palms meeting above the shoulders are


@pytest.mark.parametrize(("group", "sides"), [("left_hand", [0]), ("right_hand", [1]), ("hands", [0, 1]),
                                              ("arms", [0, 1]), ("body", [0, 1])])
def test_every_robot_group_of_a_contact_sub_goal_has_its_hands_exempted(scene: Scene, group: str,
                                                                        sides: list[int]) -> None:
    assert group in ROBOT_GROUPS
    pairs = contact_exemptions([SubgoalSpec("g", "contact", group, "left_hand", 0.1, ())], scene)
    assert [s for s, _ in pairs] == sides
    expected = sorted(int(g) for g in scene.human_geom_ids[list(scene.body.groups["left_hand"])])
    assert all(sorted(geoms) == expected for _, geoms in pairs)
