"""Walk-up steps paced to what the swing leg follows (sim/step_pace.py, FootLockConfig(pace=...)): the cap per
frame against the straight line worked out by hand (a 3-4-5 triangle) and a brute-force replay of a recorded step,
each decision both ways (a move just within and just beyond the frame's cap; the carried foot keeps its turn;
the other waits while one is carried and in the frame it is put down), the re-solve within a frame, the foot
lock's planting of a carried foot, the settings' checks, and the option reaching the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.retarget.ik import RobotIK
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.frame_targets import fill_targets
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.step_pace import StepPace

HOME = np.array([0.08, 0.08])
FPS = 10.0
STAND = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])


def _pace(speed: float = 1.0, height: float = 0.08) -> StepPace:
    p = StepPace(speed, height, FPS, HOME)  # c = 0.1 m per frame
    p(STAND)
    return p


def test_a_move_within_the_frames_cap_passes_and_one_beyond_is_carried_by_the_cap() -> None:
    for dx, carried in ((0.0999, False), (0.1001, True)):
        p = _pace()
        raw = STAND + np.array([[dx, 0.0, 0.01], [0.0, 0.0, 0.0]])
        out = p(raw)
        assert p.carried == [carried, False]
        if carried:
            np.testing.assert_allclose(out[0, :2], STAND[0, :2] + [0.1, 0.0], atol=1e-12)
            assert out[0, 2] == pytest.approx(0.16)  # raised to home + h_s
        else:
            np.testing.assert_array_equal(out, raw)
    p = _pace()
    raw = STAND + np.array([[0.3, 0.4, 0.2], [0.0, 0.0, 0.0]])  # 0.5 m along (0.6, 0.8); the recording 0.2 m up
    out = p(raw)
    np.testing.assert_allclose(out[0], [0.06, 0.18, 0.28], atol=1e-12)  # by hand: 0.1 × (0.6, 0.8); z as recorded
    np.testing.assert_array_equal(out[1], STAND[1])


def test_a_carried_target_catches_up_with_a_recorded_step_as_a_brute_force_replay_does() -> None:
    rng = np.random.default_rng(7)
    track = np.cumsum(rng.uniform(0.0, 0.25, size=(12, 2)), axis=0)  # a fast recorded walk of the left foot
    track[6:] = track[5]  # ... which then stands
    p = _pace(speed=1.5)  # c = 0.15 m per frame
    ref = STAND[0, :2].copy()
    for k in range(12):
        raw = STAND.copy()
        raw[0, :2] = STAND[0, :2] + track[k]
        out = p(raw)
        gap = raw[0, :2] - ref
        d = math.hypot(*gap)
        ref = raw[0, :2].copy() if d <= 0.15 else ref + gap * 0.15 / d  # the reference: a step of at most c
        np.testing.assert_allclose(out[0, :2], ref, atol=1e-12)
        assert p.carried[0] == (d > 0.15)
    assert not p.carried[0] and np.array_equal(out[0], raw[0])  # caught up: on the recording, put down
    assert p.carried_frames > 0


def test_one_foot_is_carried_at_a_time_and_the_other_waits_until_it_is_put_down() -> None:
    p = _pace()
    raw = STAND + np.array([[0.35, 0.0, 0.0], [0.2, 0.0, 0.1]])  # both move beyond the cap, the left farther
    out = p(raw)
    assert p.carried == [True, False]
    np.testing.assert_array_equal(out[1], STAND[1])  # the right waits where it stood (and does not lift)
    raw2 = STAND + np.array([[0.35, 0.0, 0.0], [0.6, 0.0, 0.0]])  # now the right's gap is larger: the left keeps the turn
    out = p(raw2)
    assert p.carried == [True, False]
    np.testing.assert_allclose(out[0, :2], STAND[0, :2] + [0.2, 0.0], atol=1e-12)
    np.testing.assert_array_equal(out[1], STAND[1])
    out = p(raw2)
    assert p.carried == [True, False]  # 0.2 → 0.3
    out = p(raw2)  # the left: 0.3 → 0.35 within the cap: put down on the recording; the right still waits
    assert p.carried == [False, False]
    np.testing.assert_array_equal(out[0], raw2[0])
    np.testing.assert_array_equal(out[1], STAND[1])
    out = p(raw2)  # then the right is carried
    assert p.carried == [False, True]
    np.testing.assert_allclose(out[1, :2], STAND[1, :2] + [0.1, 0.0], atol=1e-12)
    np.testing.assert_array_equal(out[0], raw2[0])


def test_a_foot_within_the_cap_passes_while_no_foot_is_carried() -> None:
    p = _pace()
    raw = STAND + np.array([[0.05, 0.0, 0.0], [0.08, 0.0, 0.1]])  # both within the cap: nothing waits
    np.testing.assert_array_equal(p(raw), raw)
    assert p.carried == [False, False]


def test_the_lag_is_the_paced_feets_mean_offset_from_the_recordings() -> None:
    p = _pace()
    raw = STAND + np.array([[0.5, 0.0, 0.0], [0.3, 0.2, 0.0]])  # the left carried 0.1, the right waits
    p(raw)
    np.testing.assert_allclose(p.lag, [((0.1 - 0.5) + (0.0 - 0.3)) / 2, (0.0 - 0.2) / 2], atol=1e-12)
    p = _pace()
    p(STAND + 0.05)  # within the cap: nothing held back
    np.testing.assert_array_equal(p.lag, [0.0, 0.0])


def test_a_solve_again_within_a_frame_is_decided_from_the_frames_start() -> None:
    p = _pace()
    raw = STAND + np.array([[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]])
    first = p(raw)
    again = p(raw, new_frame=False)
    np.testing.assert_array_equal(first, again)  # not advanced a second time
    assert p.carried_frames == 1
    nxt = p(raw)
    np.testing.assert_allclose(nxt[0, :2], STAND[0, :2] + [0.2, 0.0], atol=1e-12)


def test_the_foot_lock_counts_a_carried_foot_as_stepping_and_plants_it_where_the_recording_stands() -> None:
    lock = FootLock((0.08, 0.08), FootLockConfig(hold_lift=0.12, pace=1.0), fps=FPS)
    plain = FootLock((0.08, 0.08), FootLockConfig(hold_lift=0.12))
    lock.apply(STAND), plain.apply(STAND)
    raw = STAND + np.array([[0.25, 0.0, 0.0], [0.0, 0.0, 0.0]])  # the recording's foot already down 25 cm ahead
    assert plain.apply(raw) is not None and plain.standing == (True, True)  # without: planted there at once
    for k in range(2):
        out = lock.apply(raw)
        assert lock.standing == (False, True)
        assert out[0, 2] == pytest.approx(0.16) and out[0, 0] == pytest.approx(0.1 * (k + 1))
    out = lock.apply(raw)
    assert lock.standing == (True, True)
    np.testing.assert_allclose(lock.planted[0], [0.25, 0.1, 0.08], atol=1e-12)


def test_pace_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="pace"):
        FootLockConfig(pace=0.0)
    with pytest.raises(ConfigError, match="pace_height"):
        FootLockConfig(pace=1.0, pace_height=0.03)  # not above lift (0.04): the lock would plant it
    with pytest.raises(ConfigError, match="fps"):
        FootLock((0.08, 0.08), FootLockConfig(pace=1.0))
    FootLock((0.08, 0.08), FootLockConfig())  # no pace: no frame rate needed


def test_the_pace_reaches_the_simulators_foot_targets() -> None:
    data = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=2))
    inter = list(data.of_label("shake_hands"))[1]
    spec = load_robot("ours")
    cfg = SimConfig.standing()
    cap = 0.5 / inter.fps
    moves: list[float] = []

    def on_frame(s: Simulator, r: object, _: object) -> None:
        lock = s._footlock
        assert lock is not None and lock.pace is not None
        if lock.pace.paced is None:
            return  # before the first frame's targets
        if prev:
            moves.append(float(np.linalg.norm(lock.pace.paced[:, :2] - prev[-1][:, :2], axis=1).max()))
        prev.append(lock.pace.paced.copy())

    prev: list[np.ndarray] = []
    sim = Simulator(spec, "shake_hands", SimConfig.standing(foot_lock=FootLockConfig(
        hold_lift=0.12, hold_in_contact=True, pace=0.5)))
    run_episode(sim, GroundTruthSource(), inter, on_frame=on_frame)
    assert sim._footlock.pace.carried_frames > 0  # type: ignore[union-attr]
    assert max(moves) <= cap + 1e-9
    sim = Simulator(spec, "shake_hands", cfg)
    assert sim.config.foot_lock.pace is None  # the standing mode's default here: no pace


@pytest.mark.parametrize("pace_base", [False, True])
def test_pace_base_holds_the_iks_base_target_back_with_the_feet(pace_base: bool, monkeypatch) -> None:  # noqa: ANN001
    data = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=2))
    inter = list(data.of_label("shake_hands"))[1]
    sim = Simulator(load_robot("ours"), "shake_hands", SimConfig.standing(foot_lock=FootLockConfig(
        hold_lift=0.12, hold_in_contact=True, pace=0.5, pace_base=pace_base)))
    bases: list[np.ndarray] = []
    solve = RobotIK.solve

    def spy(self, world, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        bases.append(np.array(world[0]))
        return solve(self, world, *args, **kwargs)

    monkeypatch.setattr(RobotIK, "solve", spy)
    src = GroundTruthSource()
    src.reset(inter)
    first = src.targets(0)
    sim.reset(inter)
    sim.settle(sim.retarget(first.keys, frame=0, subevent=first.subevent))
    held = 0
    for _ in range(30):
        f = src.targets(sim.frame + 1)
        tg = sim.retarget(f.keys, frame=sim.frame + 1, subevent=f.subevent, contact=f.contact,
                          contact_inside=f.contact_inside, contact_inside_next=f.contact_inside_next)
        recorded = sim.frame_R.to_world(fill_targets(np.asarray(tg, dtype=np.float64), sim._home_keys))[0]
        bases.clear()
        sim.step(tg, subevent=f.subevent)
        lock = sim._footlock
        if all(lock.standing):  # type: ignore[union-attr]
            continue  # the steadied base filters it then
        lag = lock.pace.lag  # type: ignore[union-attr]
        held += bool(np.any(lag != 0.0))
        want = recorded[:2] + (lag if pace_base else 0.0)
        np.testing.assert_allclose(bases[0][:2], want, atol=1e-9)
    assert held > 0  # frames with feet held back were checked
