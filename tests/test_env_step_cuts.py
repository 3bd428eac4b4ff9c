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


def test_warning_monitor_counts_as_the_replaced_code_did():
    """Quiet steps, new warnings (NaN state), counters reset by MuJoCo (go down), a second data object."""
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
