"""The per-step cuts of issue 26's throughput follow-up against the code they replaced, bitwise.

Each reference below is the replaced code, verbatim in what it computes; every cut must give the same numbers
(``==`` on floats, ``assert_array_equal``), on every branch the replaced code had."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from socialaff_sim.environment.episode_end import WARNING_NAMES, EpisodeEnd, WarningMonitor, body_up, tilt_cosine
from socialaff_sim.sim.stage import key_frames


# -- the replaced code -------------------------------------------------------------------------------------
def key_frames_reference(scene, data) -> np.ndarray:
    return np.array([data.site_xpos[i] if k == "site" else data.xpos[i]
                     for k, i in zip(scene.frame_kinds, scene.frame_ids, strict=True)])


def tilt_cosine_reference(quat, up) -> float:
    w, x, y, z = (float(v) for v in quat)
    n = w * w + x * x + y * y + z * z
    row = (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z)
    return (row[0] * float(up[0]) + row[1] * float(up[1]) + row[2] * float(up[2])) / max(n, 1e-12)


class WarningMonitorReference:
    def __init__(self) -> None:
        self._index = np.array([int(w) for w in WARNING_NAMES.values()])
        self._last = np.zeros(len(WARNING_NAMES), dtype=np.int64)
        self.totals = dict.fromkeys(WARNING_NAMES, 0)

    def _counts(self, data) -> np.ndarray:
        number = getattr(data.warning, "number", None)
        if number is None:
            return np.array([data.warning[i].number for i in self._index], dtype=np.int64)
        return np.asarray(number, dtype=np.int64)[self._index]

    def reset(self, data) -> None:
        self._last = self._counts(data)

    def step(self, data) -> dict[str, int]:
        now = self._counts(data)
        if np.array_equal(now, self._last):
            return dict.fromkeys(WARNING_NAMES, 0)
        new = np.where(now >= self._last, now - self._last, now)
        self._last = now
        out = {name: int(n) for name, n in zip(WARNING_NAMES, new, strict=True)}
        for name, n in out.items():
            self.totals[name] += n
        return out


# -- key frames ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kinds", [("body",) * 5, ("site",) * 5, ("body", "site", "site", "body", "site")])
def test_key_frames_gathers_what_the_row_by_row_code_did(kinds):
    """Sites from ``site_xpos``, bodies from ``xpos``: a kind read from the wrong array fails (the arrays differ)."""
    rng = np.random.default_rng(0)
    data = SimpleNamespace(site_xpos=rng.normal(size=(9, 3)), xpos=rng.normal(size=(11, 3)))
    scene = SimpleNamespace(frame_kinds=kinds, frame_ids=np.array([4, 0, 8, 2, 7]))
    got = key_frames(scene, data)
    np.testing.assert_array_equal(got, key_frames_reference(scene, data))
    for r, (k, i) in enumerate(zip(kinds, scene.frame_ids, strict=True)):  # and by hand
        assert got[r].tolist() == (data.site_xpos if k == "site" else data.xpos)[i].tolist()
    got[0] = 99.0  # a copy, not a view of the data
    assert not (data.xpos == 99.0).any() and not (data.site_xpos == 99.0).any()


def test_key_frames_in_the_environment_equal_the_row_by_row_code():
    import gymnasium as gym
    env = gym.make("socialaff_sim/SocialAffordance-v0", max_frames=6)
    env.reset(seed=1)
    for _ in range(4):
        env.step(env.action_space.sample())
    sim = env.unwrapped.simulator
    np.testing.assert_array_equal(key_frames(sim.scene, sim.data), key_frames_reference(sim.scene, sim.data))
    env.close()


# -- the fall test's tilt -----------------------------------------------------------------------------------
def test_tilt_cosine_equals_the_replaced_arithmetic_bit_for_bit():
    rng = np.random.default_rng(1)
    for _ in range(500):
        quat, up = rng.normal(size=4), rng.normal(size=3)
        assert tilt_cosine(quat, up) == tilt_cosine_reference(quat, up)
        q32 = quat.astype(np.float32)  # float32 input: the same widening to float64 as float(v)
        assert tilt_cosine(q32, up) == tilt_cosine_reference(q32, up)
    # and against the rotation matrix (an independent reference)
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, quat)
    up = np.array([0.3, -0.2, 0.9])
    assert tilt_cosine(quat, up) == pytest.approx(float(mat.reshape(3, 3)[2] @ up), abs=1e-12)


@pytest.mark.parametrize("qadr", [np.arange(7), np.array([0, 1, 2, 9, 4, 12, 5])])
def test_fall_test_reads_the_root_quaternion_where_the_replaced_code_did(qadr):
    """A slice when the root's quaternion is consecutive in qpos, the gather otherwise: the same four numbers."""
    home = np.zeros(13)
    home[3] = 1.0
    scene = SimpleNamespace(robot_qadr=qadr, home_qpos=home)
    sim = SimpleNamespace(home_key_frames=np.array([[0.0, 0.0, 1.0]] * 5), scene=scene)
    end = EpisodeEnd(0.5, 60.0, True)
    end.reset(sim)  # type: ignore[arg-type]
    qpos = np.random.default_rng(2).normal(size=13)
    np.testing.assert_array_equal(qpos[end._quat], qpos[qadr[3:7]])
    assert isinstance(end._quat, slice) == bool((np.diff(qadr[3:7]) == 1).all())
    up = body_up(home[3:7])
    assert tilt_cosine(qpos[end._quat], up) == tilt_cosine_reference(qpos[qadr[3:7]], up)


# -- MuJoCo's warning counters ------------------------------------------------------------------------------
def _ball() -> tuple[mujoco.MjModel, mujoco.MjData]:
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>")
    return m, mujoco.MjData(m)


def test_warning_monitor_counts_as_the_replaced_code_did(tmp_path, monkeypatch):
    """Quiet steps, new warnings (NaN state), counters reset by MuJoCo (go down), a second data object."""
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its warnings to MUJOCO_LOG.TXT in the working directory
    m, d = _ball()
    new, old = WarningMonitor(), WarningMonitorReference()
    new.reset(d)
    old.reset(d)
    seen_nonzero = seen_drop = False
    for i in range(40):
        if i % 7 == 3:
            d.qvel[0] = np.nan  # MuJoCo warns (bad_qvel) and resets the data
        if i == 20:
            mujoco.mj_resetData(m, d)  # the counters go down
            seen_drop = True
        mujoco.mj_step(m, d)
        a, b = new.step(d), old.step(d)
        assert a == b and all(type(v) is int for v in a.values())
        seen_nonzero |= any(a.values())
    assert seen_nonzero and seen_drop and new.totals == old.totals and new.totals["bad_qvel"] > 0
    m2, d2 = _ball()  # another data: its own counters, not the first one's view
    d2.qpos[0] = np.nan
    mujoco.mj_step(m2, d2)
    assert new.step(d2) == old.step(d2)


def test_warning_monitor_without_a_counter_view():
    """Bindings without ``warning.number``: the counters are read one by one, as before."""
    stats = [SimpleNamespace(number=0) for _ in range(len(mujoco.mjtWarning.__members__))]
    data = SimpleNamespace(warning=stats)
    new, old = WarningMonitor(), WarningMonitorReference()
    new.reset(data)
    old.reset(data)
    for i in range(6):
        stats[int(mujoco.mjtWarning.mjWARN_BADQACC)].number += i % 2
        if i == 4:
            stats[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 0
        assert new.step(data) == old.step(data)
    assert new.totals == old.totals and new.totals["bad_qacc"] > 0


# -- reach, IK errors, quaternion blends: np.linalg.norm's arithmetic without its wrapper ------------------------
def reachable_targets_reference(model, targets, world, seg_a, seg_b, radius) -> np.ndarray:
    from socialaff_sim.sim.reach import AXIS_SAMPLES, point_segment_distance
    base = world[0]
    heights = np.linspace(-model.base_height, model.shoulder_height, AXIS_SAMPLES)
    axis = base[None, :] + heights[:, None] * np.array([0.0, 0.0, 1.0])
    trunk_gap = (point_segment_distance(axis, seg_a, seg_b) - radius[None]).min()
    base_ok = bool(trunk_gap >= model.trunk_radius + model.clearance)
    out = np.zeros(5, dtype=bool)
    out[0] = base_ok
    if not base_ok:
        return out
    hand_gap = (point_segment_distance(world[1:3], seg_a, seg_b) - radius[None]).min(axis=1)
    shoulder = targets[0] + model.shoulders
    hip = targets[0] + model.hips
    out[1:3] = (np.linalg.norm(targets[1:3] - shoulder, axis=1) <= model.arm) & (
        hand_gap >= model.hand_reach + model.clearance)
    if len(model.base_r):
        own = point_segment_distance(targets[1:3], targets[0] + model.base_a, targets[0] + model.base_b) - model.base_r
        out[1:3] &= own.min(axis=1) >= model.wrist_core + model.clearance
    out[3:5] = np.linalg.norm(targets[3:5] - hip, axis=1) <= model.leg
    return out


def test_reachable_targets_equal_the_two_pass_code_on_both_branches():
    """The axis and the hands in one distance pass: the same verdicts, with the base in and out of the person."""
    import gymnasium as gym

    from socialaff_sim.sim.reach import point_segment_distance, reachable_targets
    env = gym.make("socialaff_sim/SocialAffordance-v0", max_frames=6)
    env.reset(seed=3)
    sim = env.unwrapped.simulator
    model = sim._stage.reach
    seg_a, seg_b, radius = sim._segments
    rng = np.random.default_rng(4)
    home = sim.home_key_frames
    verdicts = set()
    for i in range(300):
        t = i % seg_a.shape[0]
        tg = home + rng.normal(scale=0.25, size=(5, 3))
        world = sim.frame_R.to_world(tg)
        if i % 3 == 0:  # the base inside the person: the first branch
            world[0] = seg_a[t, 0]
        got = reachable_targets(model, tg, world, seg_a[t], seg_b[t], radius)
        np.testing.assert_array_equal(got, reachable_targets_reference(model, tg, world, seg_a[t], seg_b[t], radius))
        verdicts.add((bool(got[0]), bool(got[1:].any())))
    assert {(False, False), (True, True)} <= verdicts
    # and a point's distances do not depend on the other points of the pass
    p = rng.normal(size=(8, 3))
    both = point_segment_distance(p, seg_a[0], seg_b[0])
    np.testing.assert_array_equal(both[:6], point_segment_distance(p[:6], seg_a[0], seg_b[0]))
    np.testing.assert_array_equal(both[6:], point_segment_distance(p[6:], seg_a[0], seg_b[0]))
    env.close()


def nlerp_reference(q0, q1, a):
    sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    q = (1.0 - a) * q0 + a * sign * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def test_nlerp_equals_the_replaced_code_both_ways_round():
    from socialaff_sim.sim.substeps import nlerp
    rng = np.random.default_rng(6)
    a = (np.arange(1, 10) / 9)[:, None]
    flips = 0
    for _ in range(200):
        q0, q1 = rng.normal(size=4), rng.normal(size=4)
        flips += float(q0 @ q1) < 0
        np.testing.assert_array_equal(nlerp(q0, q1, a), nlerp_reference(q0, q1, a))
        np.testing.assert_array_equal(nlerp(q0, q1, 0.3), nlerp_reference(q0, q1, 0.3))
    assert 0 < flips < 200  # the shortest-way-round sign taken both ways
    q = nlerp(np.array([1.0, 0, 0, 0]), np.array([0.0, 0, 0, 1.0]), 0.5)  # halfway about z: an independent value
    np.testing.assert_allclose(q, [np.sqrt(0.5), 0, 0, np.sqrt(0.5)], rtol=1e-15)


# -- the action path ----------------------------------------------------------------------------------------
def clip_reference(decoder, action):
    a = np.asarray(action, dtype=np.float64)
    n = decoder._rows
    if a.shape == (n * 3,):
        a = a.reshape(n, 3)
    if not np.isfinite(a).all():
        raise ValueError
    return np.minimum(np.maximum(a, decoder.space.low), decoder.space.high)


@pytest.mark.parametrize("mode", ["targets", "residual"])
def test_action_clip_equals_the_replaced_code(mode):
    from socialaff_sim.environment.actions import ActionDecoder
    from socialaff_sim.environment.config import EnvConfig
    from socialaff_sim.errors import SimulationError
    dec = ActionDecoder(EnvConfig(action_mode=mode), feasible=None)  # type: ignore[arg-type]
    rng = np.random.default_rng(8)
    low, high = dec.space.low, dec.space.high
    clipped = 0
    for _ in range(200):
        a = rng.uniform(low - 1.0, high + 1.0)
        for x in (a, a.astype(np.float32), a.ravel()):
            got = dec.clip(x)
            np.testing.assert_array_equal(got, clip_reference(dec, x))
            assert got.dtype == np.float64
        clipped += bool((a < low).any() or (a > high).any())
    assert clipped > 0
    bad = rng.uniform(low, high)
    bad[1, 2] = np.nan
    with pytest.raises(SimulationError):
        dec.clip(bad)


# -- the harness force ---------------------------------------------------------------------------------------
def harness_norm_reference(meter, data) -> float:
    import math
    nefc = data.nefc
    if meter._weld < 0 or nefc == 0:
        return 0.0
    off = int(meter._eq_rows_before @ data.eq_active[: meter._weld]) if meter._weld else 0
    if off + 3 <= nefc and data.efc_id[off] == meter._weld and data.efc_type[off] == meter._eq_type:
        x, y, z = data.efc_force[off: off + 3].tolist()
        return math.sqrt(x * x + y * y + z * z)
    return float(np.linalg.norm(meter.harness_force(data)))


def test_harness_norm_with_the_weld_row_looked_up_equals_the_summed_one():
    """Every pattern of active equalities before the weld, each twice (the second from the lookup), against the
    replaced sum and against the general Jᵀλ path."""
    import gymnasium as gym
    env = gym.make("socialaff_sim/SocialAffordance-v0", interactions="hand_over", max_frames=6)
    env.reset(seed=0)
    sim = env.unwrapped.simulator
    meter, m, d = sim._stage.stepper.support, sim.scene.model, sim.data
    assert meter._weld > 0  # equalities (grips) come before the harness weld in this scene
    rng = np.random.default_rng(9)
    saved = d.eq_active.copy()
    patterns = set()
    for i in range(2 * 2 ** min(meter._weld, 4)):
        d.eq_active[: meter._weld] = rng.integers(0, 2, meter._weld)
        mujoco.mj_forward(m, d)
        got = meter._harness_norm(d)
        assert got == harness_norm_reference(meter, d)
        assert got == pytest.approx(float(np.linalg.norm(meter.harness_force(d))), rel=1e-9, abs=1e-9)
        patterns.add(d.eq_active[: meter._weld].tobytes())
    assert len(patterns) > 1 and set(meter._weld_row) >= patterns
    d.eq_active[:] = saved
    env.close()
