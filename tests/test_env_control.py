"""The control period (``EnvConfig.control_dt``): a data frame split into env steps, the IK solved once per
frame while the action holds and again when it changes, the physics of a held action that of one step per frame."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import SocialAffordanceEnv
from socialaff_sim.environment.config import physics_config
from socialaff_sim.environment.control import ControlClock, control_steps_per_frame
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.ik import RobotIK
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.simulator import Simulator

FRAMES = 10
DT = 0.015


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=5, config=SyntheticConfig(interactions=("shake_hands", "hand_over"),
                                                           instances_per_interaction=2))


def make(data, control_dt, **kw) -> SocialAffordanceEnv:
    kw.setdefault("max_frames", FRAMES)
    kw.setdefault("action_mode", "residual")
    return SocialAffordanceEnv(data=data, control_dt=control_dt, **kw)


def test_control_steps_per_frame_rounds_the_frame_over_the_period():
    # 10 fps, 12 physics steps a frame: 0.1 s / 0.015 s = 6.7 -> 7 control steps
    assert control_steps_per_frame(10.0, 12, 0.015) == 7
    assert control_steps_per_frame(15.0, 8, 0.015) == 4  # 4.44 -> 4
    assert control_steps_per_frame(12.0, 10, 0.02) == 4  # 4.17 -> 4
    assert control_steps_per_frame(10.0, 12, None) == 1  # one step per frame
    assert control_steps_per_frame(10.0, 12, 0.001) == 12  # never fewer than one physics step a control step
    assert control_steps_per_frame(10.0, 12, 0.5) == 1  # never more than a frame


def test_clock_bounds_cover_the_frame_in_near_equal_parts():
    clock = ControlClock(0.015)
    clock.reset(10.0, 12)
    assert clock.bounds == (1, 3, 5, 6, 8, 10, 12)  # floor(j * 12 / 7), j = 1 … 7
    sizes = np.diff((0, *clock.bounds))
    assert sizes.sum() == 12 and sizes.max() - sizes.min() <= 1 and sizes.min() >= 1
    assert clock.end_of(0) == 1 and clock.end_of(1) == 3 and clock.end_of(10) == 12
    assert clock.step_seconds == pytest.approx(1.0 / 120.0)
    none = ControlClock(None)
    none.reset(10.0, 12)
    assert none.bounds == (12,) and none.per_frame == 1


def test_clock_solves_at_a_frame_start_and_on_changed_targets_only():
    clock = ControlClock(0.015)
    clock.reset(10.0, 12)
    a, b = np.zeros((5, 3)), np.ones((5, 3))
    assert clock.needs_solve(0, a)  # a frame's first control step always solves
    assert not clock.needs_solve(3, a)  # the same targets within the frame: no new solve
    assert clock.needs_solve(5, b)  # changed: solve
    assert not clock.needs_solve(6, b)
    assert clock.needs_solve(0, b)  # a new frame solves even for the same targets


@pytest.mark.parametrize("bad", [0.0, -0.01, 2.0, "0.02"])
def test_bad_control_period_is_a_config_error(data, bad):
    with pytest.raises(ConfigError, match="control_dt"):
        make(data, bad)


def test_bad_resolve_iterations_is_a_config_error(data):
    with pytest.raises(ConfigError, match="resolve_iterations"):
        make(data, DT, resolve_iterations=0)


def test_env_steps_advance_the_physics_by_the_control_period(data):
    env = make(data, DT)
    env.reset(seed=0)
    sim = env.simulator
    m, n = env.clock.per_frame, sim.n_sub
    assert m == control_steps_per_frame(sim.interaction.fps, n, DT) and m > 1
    bounds = (0, *env.clock.bounds)
    zero = np.zeros((5, 3), np.float32)
    for j in range(2 * m):
        obs, _, term, trunc, info = env.step(zero)
        assert not (term or trunc)
        frame, k = divmod(j + 1, m)
        assert info["frame"] == frame  # the frame advances on its last control step only
        steps = frame * n + bounds[k]
        assert info["time"] == pytest.approx(steps / (n * sim.interaction.fps))
        assert obs["progress"][0] == pytest.approx((frame + bounds[k] / n) / (sim.n_frames - 1), abs=1e-6)
    assert env.metadata["render_fps"] == pytest.approx(m * sim.interaction.fps)


def _play(env: SocialAffordanceEnv, seed: int, actions: list[np.ndarray] | None = None) -> list[tuple]:
    """(frame, observation, reward, terms, terminated, reason) of every step of one episode."""
    obs, _ = env.reset(seed=seed)
    out = [(0, obs, 0.0, {}, False, None)]
    i, done = 0, False
    while not done:
        a = np.zeros((5, 3), np.float32) if actions is None else actions[min(i, len(actions) - 1)]
        obs, r, term, trunc, info = env.step(a)
        out.append((info["frame"], obs, r, {k: v for k, v in info.items() if k.startswith("reward_")}, term,
                    info["termination_reason"]))
        i, done = i + 1, term or trunc
    return out


def test_a_held_action_gives_the_physics_of_one_step_per_frame_bitwise(data):
    """Zero residuals (the action held through every frame): at every frame boundary the control-period env's
    observation is bitwise the one-step-per-frame env's, and its rewards over the frame sum to the frame's."""
    for seed in (0, 1, 2):
        framewise = _play(make(data, None), seed)
        control = _play(make(data, DT), seed)
        # the reset and every step that completed a frame (the frame number moved on)
        at_frame = [control[0]] + [c for prev, c in zip(control, control[1:], strict=False) if c[0] != prev[0]]
        assert len(at_frame) == len(framewise) and len(control) > len(framewise)
        for f, c in zip(framewise, at_frame, strict=True):
            assert f[0] == c[0]
            for key in f[1]:
                np.testing.assert_array_equal(f[1][key], c[1][key], err_msg=key)
            assert (f[4], f[5]) == (c[4], c[5])
        f_total = sum(x[2] for x in framewise)
        c_total = sum(x[2] for x in control)
        assert c_total == pytest.approx(f_total, abs=1e-9)
        for name in framewise[1][3]:
            assert sum(x[3].get(name, 0.0) for x in control) == pytest.approx(sum(x[3].get(name, 0.0)
                                                                                  for x in framewise), abs=1e-9)


def test_the_affordance_is_scored_on_a_frames_last_control_step_only(data):
    env = make(data, DT)
    env.reset(seed=1)
    m = env.clock.per_frame
    zero = np.zeros((5, 3), np.float32)
    seen = []
    for j in range(3 * m):
        _, r, _, _, info = env.step(zero)
        seen.append(info["reward_affordance"])
        terms = [v for k, v in info.items() if k.startswith("reward_")]
        assert r == pytest.approx(sum(terms))
    seen = np.array(seen).reshape(3, m)
    assert (seen[:, :-1] == 0.0).all() and (seen[:, -1] > 0.0).all()


def test_ik_solved_once_per_frame_while_held_and_again_when_the_action_changes(data, monkeypatch):
    calls: list[int | None] = []
    original = Simulator.solve

    def counting(self, targets, subevent=None, iterations=None):
        calls.append(iterations)
        return original(self, targets, subevent, iterations)

    monkeypatch.setattr(Simulator, "solve", counting)
    env = make(data, DT)
    env.reset(seed=0)
    m = env.clock.per_frame
    zero = np.zeros((5, 3), np.float32)
    for _ in range(2 * m):
        env.step(zero)
    assert calls == [None, None]  # held: one full solve per frame
    calls.clear()
    rng = np.random.default_rng(0)
    for _ in range(m):  # a new residual every control step
        env.step(rng.uniform(-0.05, 0.05, (5, 3)).astype(np.float32))
    assert calls == [None] + [1] * (m - 1)  # the frame's first: a full solve; later: resolve_iterations steps


def test_a_changed_action_within_the_frame_moves_the_servo_references(data):
    """The re-solve mid-frame reaches the physics: the servo references of the remaining physics steps go to
    the new solution (and the references already used stay as they were)."""
    env = make(data, DT)
    env.reset(seed=0)
    stepper = env.simulator._stage.stepper
    env.step(np.zeros((5, 3), np.float32))
    k = stepper.k
    before = stepper._ctrls.copy()
    q_ik = env.simulator._stage.ik.configuration.q.copy()
    offset = np.zeros((5, 3), np.float32)
    offset[1:3, 2] = 0.2  # both wrists 20 cm higher
    env.step(offset)
    np.testing.assert_array_equal(stepper._ctrls[:k], before[:k])
    assert not np.allclose(stepper._ctrls[k:], before[k:])
    assert not np.array_equal(env.simulator._stage.ik.configuration.q, q_ik)


def test_resolve_iterations_cap_the_ik_steps_within_a_frame(data, monkeypatch):
    seen: list[int] = []
    original = RobotIK.solve

    def record(self, *args, **kw):
        res = original(self, *args, **kw)
        seen.append(res.iterations)
        return res

    monkeypatch.setattr(RobotIK, "solve", record)
    env = make(data, DT, action_mode="targets")
    env.reset(seed=0)
    m = env.clock.per_frame
    seen.clear()
    rng = np.random.default_rng(1)
    for _ in range(m):
        env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
        if env._done:
            break
    assert all(it == 1 for it in seen[1:]) and len(seen) >= 2


def test_same_seed_same_control_steps_in_two_fresh_envs(data):
    def run(action_seed: int) -> list[tuple]:
        env = make(data, DT, action_mode="targets")
        rng = np.random.default_rng(action_seed)
        out = []
        for seed in (3, 4):
            obs, _ = env.reset(seed=seed)
            out.append((obs, 0.0))
            for _ in range(15):
                obs, r, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high)
                                                  .astype(np.float32))
                out.append((obs, r))
                if term or trunc:
                    break
        return out

    a, b, c = run(7), run(7), run(8)
    assert len(a) == len(b)
    for (oa, ra), (ob, rb) in zip(a, b, strict=True):
        assert ra == rb
        for k in oa:
            np.testing.assert_array_equal(oa[k], ob[k], err_msg=k)
    assert any(not np.array_equal(x[0]["joint_pos"], y[0]["joint_pos"]) for x, y in zip(a, c, strict=False))


def test_pickled_mid_frame_the_env_goes_on_as_the_original(data):
    env = make(data, DT)
    env.reset(seed=2)
    rng = np.random.default_rng(3)
    for _ in range(env.clock.per_frame + 2):  # into the second frame, within it
        env.step(rng.uniform(-0.05, 0.05, (5, 3)).astype(np.float32))
    assert env.simulator.substep > 0
    copy = pickle.loads(pickle.dumps(env))
    assert copy.simulator.substep == env.simulator.substep and copy.simulator.frame == env.simulator.frame
    for _ in range(5):
        a = rng.uniform(-0.05, 0.05, (5, 3)).astype(np.float32)
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = copy.step(a)
        assert r1 == r2
        for k in o1:
            np.testing.assert_array_equal(o1[k], o2[k], err_msg=k)


def test_a_held_action_with_the_balance_controller_gives_its_frame_physics(data):
    """The physics-rate balance controller (``SimConfig.balance``) plans per frame target: with a held action the
    control steps reproduce the one-step-per-frame physics with it too."""
    cfg = dataclasses.replace(physics_config("fast"), balance=BalanceConfig())
    framewise = _play(make(data, None, sim_config=cfg, max_frames=6), 0)
    control = _play(make(data, DT, sim_config=cfg, max_frames=6), 0)
    at_frame = [control[0]] + [c for prev, c in zip(control, control[1:], strict=False) if c[0] != prev[0]]
    assert len(at_frame) == len(framewise)
    for f, c in zip(framewise, at_frame, strict=True):
        for key in ("robot_keys", "joint_pos", "joint_vel"):
            np.testing.assert_array_equal(f[1][key], c[1][key], err_msg=key)


def test_actions_outside_the_space_are_clipped_on_every_control_step(data):
    """A residual of 9 m is the bound's 0.3 m, mid-frame too: the same physics as the bound itself."""
    runs = []
    for value in (9.0, 0.3):
        env = make(data, DT)
        env.reset(seed=1)
        obs = None
        for _ in range(env.clock.per_frame + 2):
            a = np.zeros((5, 3), np.float32)
            a[1:3, 2] = value  # the wrists up
            obs, *_ = env.step(a)
        runs.append(obs)
    for k in runs[0]:
        np.testing.assert_array_equal(runs[0][k], runs[1][k], err_msg=k)
