"""The environment under any action: the target envelope, termination reasons, MuJoCo's warnings.

Each termination reason is produced by a situation built for it; the envelope is checked
against its geometry computed here, and against physics with the projection switched off.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import gymnasium as gym

import mujoco
import numpy as np
import pytest
from conftest import check_env_strict, load_script
from scipy.spatial.transform import Rotation

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import ENV_IDS, SocialAffordanceEnv
from socialaff_sim.environment.action_limits import EnvelopeConfig, BodyEnvelope, FeasibleTargets
from socialaff_sim.environment.episode_end import FAILURE_REASONS, TERMINATION_REASONS, WarningMonitor, tilt_angle
from socialaff_sim.errors import ConfigError

ZERO = np.zeros((5, 3), np.float32)


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands", "hand_over"), instances_per_interaction=2))


def play(env, action, seed=0, options=None, limit=400):
    """Steps of one episode with a fixed action (or a callable of the env): the last (terminated, truncated, info)."""
    env.reset(seed=seed, options=options)
    for n in range(1, limit + 1):
        _, reward, term, trunc, info = env.step(action(env) if callable(action) else action)
        assert np.isfinite(reward)
        if term or trunc:
            return n, term, trunc, info
    raise AssertionError(f"no end within {limit} steps")


# -- the envelope ---------------------------------------------------------------------------------
BODY = BodyEnvelope(arm=0.6, leg=0.8, shoulders=np.array([[0.0, 0.2, 0.45], [0.0, -0.2, 0.45]]),
                    hips=np.array([[0.0, 0.1, -0.05], [0.0, -0.1, -0.05]]), base_height=0.85, ankle_height=0.08)


def inside(body: BodyEnvelope, lim: EnvelopeConfig, t: np.ndarray, prev: np.ndarray, fps: float) -> bool:
    """The envelope's conditions, written out one by one (tolerance 1e-9 m)."""
    e = 1e-9
    base = t[0]
    ok = body.base_height - lim.base_drop * body.leg - e <= base[2] <= body.ankle_height + 0.05 + (1 + lim.base_lift) * body.leg + e
    ok &= np.hypot(*(base[:2] - prev[:2])) <= lim.base_speed / fps + e and abs(base[2] - prev[2]) <= lim.base_climb / fps + e
    for s, row in ((0, 3), (1, 4)):
        a, hip = t[row], base + body.hips[s]
        ok &= lim.ankle_floor * body.ankle_height - e <= a[2] <= body.ankle_height + lim.step_height * body.leg + e
        ok &= (a[1] - base[1]) * np.sign(body.hips[s, 1]) >= lim.stance * abs(body.hips[s, 1]) - e
        ok &= np.linalg.norm(a - hip) <= (1 + lim.leg_slack) * body.leg + e
    for s, row in ((0, 1), (1, 2)):
        ok &= np.linalg.norm(t[row] - (base + body.shoulders[s])) <= (1 + lim.arm_slack) * body.arm + e
    return bool(ok)


def test_projection_lands_inside_is_idempotent_and_keeps_what_is_inside(rng):
    lim = EnvelopeConfig()
    proj = FeasibleTargets(BODY, lim)
    prev = np.array([0.0, 0.0, 0.85])
    outside = 0
    for _ in range(300):
        t = rng.uniform([-1.0, -1.5, 0.0], [3.0, 1.5, 2.5], size=(5, 3))
        p = proj.project(t, prev, 10.0)
        assert inside(BODY, lim, p, prev, 10.0)
        np.testing.assert_allclose(proj.project(p, prev, 10.0), p, atol=1e-12)
        outside += not inside(BODY, lim, t, prev, 10.0)
    assert outside > 250  # the box is mostly outside the envelope: the test above is not vacuous
    home = np.array([[0.02, 0.01, 0.84], [0.1, 0.3, 0.5], [0.1, -0.3, 0.5], [0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
    assert inside(BODY, lim, home, prev, 10.0)
    np.testing.assert_array_equal(proj.project(home, prev, 10.0), home)


def test_projection_decisions_each_move_only_their_row():
    proj = FeasibleTargets(BODY)
    prev = np.array([0.0, 0.0, 0.85])
    home = np.array([[0.0, 0.0, 0.85], [0.1, 0.3, 0.5], [0.1, -0.3, 0.5], [0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
    far = home.copy()
    far[0, 0] = 2.0  # 2 m in one frame at 10 fps: the base goes v_h/f = 0.3 m
    assert proj.project(far, prev, 10.0)[0, 0] == pytest.approx(0.3)
    crossed = home.copy()
    crossed[3, 1] = -0.2  # left ankle right of the base
    assert proj.project(crossed, prev, 10.0)[3, 1] == pytest.approx(0.25 * 0.1)
    kick = home.copy()
    kick[4, 2] = 1.5  # right ankle at chest height
    assert proj.project(kick, prev, 10.0)[4, 2] == pytest.approx(0.08 + 0.4 * 0.8)
    reach = home.copy()
    reach[1] = [3.0, 0.2, 1.3]  # 3 m in front of the left shoulder (0, 0.2, 1.3)
    np.testing.assert_allclose(proj.project(reach, prev, 10.0)[1], [1.2, 0.2, 1.3], atol=1e-12)
    with pytest.raises(ConfigError, match="stance"):
        EnvelopeConfig(stance=1.5)


# -- termination reasons --------------------------------------------------------------------------
def test_task_complete_and_instance_end(data):
    env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual")
    n, term, trunc, info = play(env, ZERO)  # the recorded agent 1, replayed: the handshake happens
    assert (term, trunc, info["termination_reason"]) == (True, False, "task_complete") and info["success"]
    m = env.clock.per_frame  # control steps per frame (the default control period)
    assert m > 1 and n == (env.simulator.n_frames - 1) * m and info["frame"] == env.simulator.n_frames - 1
    short = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual", max_frames=5)
    n, term, trunc, info = play(short, ZERO)  # cut before the hands meet
    assert (n, term, trunc, info["termination_reason"]) == (4 * m, True, False, "instance_end") and not info["success"]
    framewise = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual", max_frames=5,
                                    control_dt=None)
    n, term, trunc, info = play(framewise, ZERO)  # one step per frame
    assert (n, term, trunc, info["termination_reason"]) == (4, True, False, "instance_end")


def test_failure_reasons(data):
    env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual")
    label = "shake_hands"
    task = env.pool.tasks[label]
    # A person who bears 1 N at most: the replayed handshake's grip is a pushing failure.
    env.pool.tasks[label] = dataclasses.replace(task, failures=tuple(
        dataclasses.replace(f, threshold=1.0) if f.kind == "contact_force" else f for f in task.failures))
    env._sims.clear()
    _, term, trunc, info = play(env, ZERO)
    assert (term, trunc, info["termination_reason"]) == (True, False, "contact_force")
    assert info["failures"]["contact_force"] and info["failed"]

    rand = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="targets", max_frames=40)
    rand.action_space.seed(0)
    _, term, _, info = play(rand, lambda e: e.action_space.sample())
    assert term and info["termination_reason"] == "self_collision"  # random targets tangle the limbs
    assert info["failures"]["self_collision"] and set(FAILURE_REASONS) >= set(info["failures"])

    keep = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="targets", max_frames=40,
                               terminate_on_failure=False)
    keep.action_space.seed(0)
    _, term, _, info = play(keep, lambda e: e.action_space.sample())
    assert info["failed"] and info["termination_reason"] == "instance_end"  # failures then only penalise


def test_time_limit_truncation_is_the_wrappers(data):
    env = gym.make("socialaff_sim/ShakeHands-v0", data=data, max_frames=12, action_mode="residual", max_episode_steps=3)
    env.reset(seed=0)
    out = [env.step(ZERO) for _ in range(3)]
    assert [(o[2], o[3], o[4]["termination_reason"]) for o in out] == [(False, False, None)] * 2 + [(False, True, None)]
    env.close()


def test_object_dropped():
    # The robot keeps its hands down at its sides; the person throws the ball anyway.
    throw = generate_dataset(seed=0, config=SyntheticConfig(interactions=("throw_catch",), instances_per_interaction=1))
    env = SocialAffordanceEnv(data=throw, action_mode="targets")

    def stand(e):
        return e.simulator.home_key_frames.astype(np.float32)

    _, term, trunc, info = play(env, stand)
    assert (term, trunc, info["termination_reason"]) == (True, False, "object_dropped")


def test_fell_threshold_decides(data):
    crouch = np.tile(np.float32([0.0, 0.0, 0.0]), (5, 1))  # every target on the floor: the base sinks to its lowest
    low = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="targets", terminate_on_failure=False,
                              fall_height=0.9, max_frames=30)
    _, term, _, info = play(low, crouch)
    assert term and info["termination_reason"] == "fell"
    home = low.simulator.home_key_frames[0, 2]
    assert low.simulator.robot_key_frames()[0, 2] < 0.9 * home
    default = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="targets", terminate_on_failure=False,
                                  max_frames=30)
    _, term, _, info = play(default, crouch)
    assert info["termination_reason"] == "instance_end"


def wxyz(r: Rotation) -> np.ndarray:
    """MuJoCo's (w, x, y, z) of a scipy rotation (scipy: x, y, z, w)."""
    return np.roll(r.as_quat(), 1)


def test_tilt_angle_against_scipy(rng):
    for _ in range(20):
        home = Rotation.random(random_state=rng)
        tilt = Rotation.from_rotvec(rng.uniform(-1.0, 1.0, 3))
        yaw = Rotation.from_euler("z", rng.uniform(-np.pi, np.pi))
        now = tilt * yaw * home
        expected = np.arccos(np.clip((now * home.inv()).apply([0, 0, 1])[2], -1, 1))
        assert tilt_angle(wxyz(now), wxyz(home)) == pytest.approx(expected, abs=1e-9)
        assert tilt_angle(wxyz(yaw * home), wxyz(home)) == pytest.approx(0.0, abs=1e-7)


def test_physics_unstable_is_a_truncation(data):
    env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual", max_frames=10)
    env.reset(seed=0)
    sim = env.simulator
    sim.data.qvel[sim.scene.robot_vadr[6]] = np.nan  # a diverged state: MuJoCo warns and resets its data
    obs, reward, term, trunc, info = env.step(ZERO)
    assert (term, trunc, info["termination_reason"]) == (False, True, "physics_unstable")
    assert info["physics_warnings"]["bad_qvel"] == 1 and env.warnings.totals["bad_qvel"] == 1
    assert np.isfinite(reward) and all(np.isfinite(v).all() for v in obs.values())
    env.reset(seed=0)
    _, _, _, _, info = env.step(ZERO)
    assert sum(info["physics_warnings"].values()) == 0 and info["termination_reason"] is None


def test_warning_monitor_counts_increases_and_resets():
    class Fake:
        def __init__(self):
            self.warning = [type("W", (), {"number": 0})() for _ in range(8)]

    d = Fake()
    mon = WarningMonitor()
    mon.reset(d)
    d.warning[5].number = 2  # bad_qacc
    assert mon.step(d)["bad_qacc"] == 2
    assert mon.step(d)["bad_qacc"] == 0
    d.warning[5].number = 1  # MuJoCo reset the data, then counted one
    assert mon.step(d)["bad_qacc"] == 1 and mon.totals["bad_qacc"] == 3


def test_reasons_are_documented():
    doc = (Path(__file__).resolve().parents[1] / "docs" / "environment.md").read_text()
    for reason in TERMINATION_REASONS:
        assert f"`{reason}`" in doc


def test_subgoal_states_and_belief_in_the_observation(data):
    env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual")
    obs, _ = env.reset(seed=0)
    names = env.rewards.subgoal_names
    seen_now = seen_met = False
    while True:
        belief = obs["subevent_belief"]
        assert belief.sum() == pytest.approx(1.0, abs=1e-6) or not belief.any()  # a probability vector, or unknown
        obs, _, term, trunc, info = env.step(ZERO)
        np.testing.assert_array_equal(obs["subgoal_achieved"], [float(info["subgoals"][n]) for n in names])
        np.testing.assert_array_equal(obs["subgoal_current"], [float(info["subgoals_now"][n]) for n in names])
        seen_now |= bool(obs["subgoal_current"].any()) and not obs["subgoal_achieved"].all()
        seen_met |= bool(obs["subgoal_achieved"].all())
        if term or trunc:
            break
    assert seen_now and seen_met  # touching before met, then met: both flags took both values


def test_servo_references_and_forces_are_clamped(data, rng):
    for robot in ("ours", "cmu"):
        env = SocialAffordanceEnv(data=data, interactions="shake_hands", robot=robot, max_frames=5)
        env.reset(seed=0)
        scene = env.simulator.scene
        m, d = scene.model, env.simulator.data
        # References: whatever posture is asked for, inside the joints' ranges.
        wild = np.array(d.qpos)
        wild[scene.act_qadr] = rng.uniform(-10.0, 10.0, len(scene.act_qadr))
        ctrl = scene.ctrl_for(wild)
        jnt = m.actuator_trnid[scene.act_ids, 0]
        q_ref = -(m.actuator_biasprm[scene.act_ids, 0] + m.actuator_gainprm[scene.act_ids, 0] * ctrl) / m.actuator_biasprm[scene.act_ids, 1]
        lim = m.jnt_limited[jnt].astype(bool)
        assert lim.any()
        assert (q_ref[lim] >= m.jnt_range[jnt[lim], 0] - 1e-9).all() and (q_ref[lim] <= m.jnt_range[jnt[lim], 1] + 1e-9).all()
        # Forces: whatever control is written, within each actuator's force range.
        assert m.nu > 0 and m.actuator_forcelimited.all() and np.isfinite(m.actuator_forcerange).all()
        d.ctrl[:] = np.where(np.arange(m.nu) % 2, 1e6, -1e6)
        mujoco.mj_forward(m, d)
        lo, hi = m.actuator_forcerange.T
        assert (d.actuator_force >= lo - 1e-9).all() and (d.actuator_force <= hi + 1e-9).all()
        assert np.isclose(d.actuator_force, lo).any() and np.isclose(d.actuator_force, hi).any()


# -- random actions, with and without the envelope ------------------------------------------------
def _stress_script():  # noqa: ANN202
    return load_script("env_stress")


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_random_actions_leave_the_physics_sound(env_id):
    """The short version of scripts/env_stress.py: 300 random steps (control periods) per action mode, robot ``ours``."""
    stress = _stress_script().stress
    for k, mode in enumerate(("targets", "residual")):
        res = stress(env_id, "ours", mode, 300, seed=k)
        assert res["steps"] == 300 and res["episodes"] >= 1
        assert res["physics_warnings"] == {} and res["mujoco_log_warnings"] == {}, res
        assert res["non_finite_steps"] == 0 and res["outside_space_steps"] == 0 and res["errors"] == {}, res
        assert res["passed"], res


def test_random_episodes_run_through_failures():
    res = _stress_script().stress("socialaff_sim/ThrowCatch-v0", "ours", "targets", 200, seed=0, terminate_on_failure=False)
    assert res["passed"] and res["physics_warnings"] == {}, res
    assert set(res["ends"]) <= {"task_complete", "instance_end", "fell"}


def test_without_the_envelope_extreme_targets_topple_the_robot():
    """Box-corner targets (each coordinate at one of its bounds, drawn at random) for the CMU humanoid handing over:
    with the projection off the robot falls within the episode (before the standing-balance IK was merged, the
    same actions made MuJoCo's solver diverge at frame 19: docs/benchmarks.md); with it on, the same actions
    play the whole track without a fall or a MuJoCo warning."""
    data = generate_dataset(seed=0, config=SyntheticConfig(interactions=("hand_over",), instances_per_interaction=2))
    outcome = {}
    for envelope in (False, True):
        env = SocialAffordanceEnv(data=data, robot="cmu", action_mode="targets", terminate_on_failure=False)
        if not envelope:
            _stress_script().identity_projection(env)
        lo, hi = env.action_space.low, env.action_space.high
        rng = np.random.default_rng(0)
        env.reset(seed=0)
        moved = 0.0
        while True:
            _, reward, term, trunc, info = env.step(np.where(rng.random((5, 3)) < 0.5, lo, hi))
            assert np.isfinite(reward)
            moved = max(moved, float(info["action_adjustment"].max()))
            if term or trunc:
                break
        outcome[envelope] = (info["termination_reason"], sum(env.warnings.totals.values()), moved > 0.5)
    assert outcome[False] == ("fell", 0, False)
    assert outcome[True] == ("instance_end", 0, True)


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_env_checker_clean_for_every_id(env_id):
    """Gymnasium's checker, warnings as errors, on every registered id (``residual`` actions; tests/test_env.py
    checks ``targets`` too) with the sub-event and sub-goal observation keys."""
    env = gym.make(env_id, max_frames=12, action_mode="residual")
    try:
        check_env_strict(env)
        assert {"subevent_belief", "subgoal_achieved", "subgoal_current"} <= set(env.observation_space.spaces)
    finally:
        env.close()
