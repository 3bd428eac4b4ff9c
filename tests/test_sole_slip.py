"""The soles' slip on the floor and the feet's steps (sim/sole_slip.py; ``foot_slip_cm``, ``foot_steps``,
``foot_step_cm`` beside the ankle's sliding path ``foot_slide_cm``): a box sole pushed along a nearly frictionless
floor against its body's own displacement, a sole twisted flat against the arc of its corners, Stubby rocked onto
its soles' front edges and back against the ankle's path by brute force, a lift-and-place step, and each decision
(the contact persists or not; touching or within the margin only; a first touch or a landing; off the floor above
the clearance or within it; the contact phase or not; the larger foot)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from socialaff_sim.sim.episode import support_summary
from socialaff_sim.sim.sole_slip import FrameSlip, SoleSlip
from socialaff_sim.sim.support import FrameSupport, SupportMeter

A, B, H = 0.11, 0.055, 0.01  # the box sole's half-extents, m (Stubby's sole)


def _box(friction: float = 1.0, margin: float = 0.0, z: float = H - 2e-4) -> tuple[mujoco.MjModel, mujoco.MjData, SoleSlip]:
    """A free box sole on a floor, its meter (one foot: the box; the step body: the box's). The floor's impedance is
    softer than MuJoCo's default (``solimp`` 0.5/0.6, elliptic cones), so that a resting box sinks 0.3 mm into it:
    with the default one it rests at distance ≈ 0 (1e-12 m), touching at some physics steps and not at others."""
    xml = f"""<mujoco><option timestep="0.002" cone="elliptic"/><worldbody>
      <geom name="floor" type="plane" size="3 3 0.1" friction="{friction} 0.005 0.0001" margin="{margin}"
            solimp="0.5 0.6 0.001"/>
      <body name="sole" pos="0 0 {z}"><freejoint/>
        <geom name="box" type="box" size="{A} {B} {H}" mass="2" friction="{friction} 0.005 0.0001" margin="{margin}"/>
      </body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    box = np.zeros(m.ngeom, dtype=bool)
    box[m.geom("box").id] = True
    return m, d, SoleSlip(m, m.geom("floor").id, [box], [m.body("sole").id])


def _pose(m: mujoco.MjModel, d: mujoco.MjData, xyz, yaw: float = 0.0) -> None:  # noqa: ANN001
    """Put the box at ``xyz`` turned by ``yaw`` about the vertical (kinematically) and run the collision."""
    d.qpos[:3] = xyz
    d.qpos[3:7] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    mujoco.mj_forward(m, d)


def _touching(m: mujoco.MjModel, d: mujoco.MjData) -> bool:
    return any(d.contact.dist[i] <= 0 for i in range(d.ncon))


def test_a_sole_pushed_along_a_nearly_frictionless_floor_slips_its_own_displacement() -> None:
    m, d, meter = _box(friction=1e-4)
    for _ in range(200):  # settle
        mujoco.mj_step(m, d)
    meter.record(d)
    meter.end_frame()
    start = d.xpos[m.body("sole").id, :2].copy()
    total, frames = 0.0, 0
    for k in range(600):
        d.xfrc_applied[m.body("sole").id, :2] = (2.0, 1.0) if k < 300 else (0.0, 0.0)  # push, then coast
        mujoco.mj_step(m, d)
        assert _touching(m, d)
        meter.record(d)
        if k % 7 == 6:
            fr = meter.end_frame()
            total += fr.slip[0]
            frames += 1
            assert fr.steps == 0
    total += meter.end_frame().slip[0]
    moved = float(np.linalg.norm(d.xpos[m.body("sole").id, :2] - start))  # straight: the path is the displacement
    assert moved > 0.3
    assert total == pytest.approx(moved, rel=1e-3)


def test_a_sole_twisted_flat_slips_the_mean_arc_of_its_corners() -> None:
    # Pressed flat, turned by 0.6 rad about its middle in 60 steps: its four corner contacts slip along arcs of
    # radius √(a² + b²); the meter sums chords, 2 r sin(Δφ/2) per step.
    m, d, meter = _box()
    n, turn = 60, 0.6
    for k in range(n + 1):
        _pose(m, d, (0.0, 0.0, H - 5e-4), yaw=turn * k / n)
        assert sum(d.contact.dist[i] <= 0 for i in range(d.ncon)) == 4
        meter.record(d)
    r = math.hypot(A, B)
    assert meter.end_frame().slip[0] == pytest.approx(n * 2 * r * math.sin(turn / n / 2), rel=1e-6)


def test_a_lift_and_place_is_a_step_not_slip_and_a_first_touch_no_step() -> None:
    m, d, meter = _box()
    body = m.body("sole").id
    down = H - 5e-4
    path = [(0.0, 0.0, 0.05), (0.0, 0.0, down), (0.0, 0.0, down),  # a first touch: no step
            (0.03, 0.0, 0.05),  # lifted and moved 3 cm in one physics step: not carried, not slip
            (0.04, 0.0, 0.05)]
    for xyz in path:
        _pose(m, d, xyz)
        meter.record(d)
    first = meter.end_frame()
    assert first == FrameSlip(slip=(0.0,), steps=0, step_length=0.0)
    for xyz in [(0.05, 0.02, down), (0.05, 0.02, down)]:  # lands in the next frame 5.4 cm from where it left
        _pose(m, d, xyz)
        meter.record(d)
    second = meter.end_frame()
    assert second.steps == 1 and second.slip == (0.0,)
    assert second.step_length == pytest.approx(math.hypot(0.05, 0.02), abs=1e-12)
    np.testing.assert_allclose(d.xpos[body, :2], [0.05, 0.02])
    # After a reset the next touch is a first touch again.
    meter.reset()
    _pose(m, d, (0.0, 0.0, 0.05))
    meter.record(d)
    _pose(m, d, (0.1, 0.0, down))
    meter.record(d)
    assert meter.end_frame().steps == 0


@pytest.mark.parametrize("height, stepped", [(0.003, False), (0.008, True)])
def test_a_foot_off_the_floor_within_the_clearance_skims_above_it_steps(height: float, stepped: bool) -> None:
    # Lifted flat by `height` above where it touched (the clearance: 5 mm), moved 2 cm over two frames, back down:
    # a skim of 2 cm (its corners' move) below the clearance, a step of 2 cm (the body's move) above it; never slip.
    m, d, meter = _box()
    down = H - 5e-4
    for xyz in [(0.0, 0.0, down), (0.0, 0.0, down), (0.005, 0.0, down + height)]:
        _pose(m, d, xyz)
        meter.record(d)
    assert meter.end_frame() == FrameSlip(slip=(0.0,), steps=0, step_length=0.0)
    for xyz in [(0.01, 0.0, down + 0.001), (0.02, 0.0, down), (0.02, 0.0, down)]:  # the highest point was a frame ago
        _pose(m, d, xyz)
        meter.record(d)
    fr = meter.end_frame()
    assert fr.slip == (0.0,)
    if stepped:
        assert (fr.steps, fr.skims) == (1, 0) and fr.step_length == pytest.approx(0.02, abs=1e-12)
    else:
        assert (fr.steps, fr.skims) == (0, 1) and fr.skim_length == pytest.approx(0.02, abs=1e-9)


def test_a_foot_tipped_off_the_floor_is_judged_by_its_lowest_contact() -> None:
    # Off the floor with its toe edge 2 mm and its heel edge 2 cm above where they touched (tipped about y), then
    # down 1 cm further on: the lowest contact stayed within the clearance, so a skim, not a step.
    m, d, meter = _box()
    down = H - 5e-4
    for xyz in [(0.0, 0.0, down), (0.0, 0.0, down)]:
        _pose(m, d, xyz)
        meter.record(d)
    pitch = -math.asin(0.009 / A)  # the +x end (toe) 9 mm below the middle, the heel 9 mm above
    d.qpos[:3] = (0.005, 0.0, down + 0.011)
    d.qpos[3:7] = [math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]
    mujoco.mj_forward(m, d)
    assert d.ncon == 0
    meter.record(d)
    _pose(m, d, (0.01, 0.0, down))
    meter.record(d)
    fr = meter.end_frame()
    assert (fr.steps, fr.skims) == (0, 1)


def test_a_contact_within_the_margin_only_is_not_touching() -> None:
    # The floor's margin reports the box 3 mm above it as a contact (distance +3 mm): not touching, so moving it
    # there slips nothing; pressed into the floor, the same move slips.
    m, d, meter = _box(margin=0.005)
    for x in (0.0, 0.02):
        _pose(m, d, (x, 0.0, H + 0.003))
        assert d.ncon > 0 and all(d.contact.dist[i] > 0 for i in range(d.ncon))
        meter.record(d)
    assert meter.end_frame() == FrameSlip(slip=(0.0,), steps=0, step_length=0.0)
    for x in (0.02, 0.04):
        _pose(m, d, (x, 0.0, H - 5e-4))
        meter.record(d)
    assert meter.end_frame().slip[0] == pytest.approx(0.02, abs=1e-12)


def _stubby_pitched(scene, angle: float, axis_x: float, axis_z: float) -> np.ndarray:  # noqa: ANN001
    """Stubby's home coordinates lowered 2 mm and turned by ``angle`` about the horizontal line along y through
    (axis_x, ·, axis_z) (the whole robot rigidly: its soles roll on their front edges)."""
    q = scene.home_qpos.copy()
    q[2] -= 0.002
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    p = q[:3] - [axis_x, 0.0, axis_z]
    q[:3] = np.array([axis_x, 0.0, axis_z]) + R @ p
    turn = np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, turn, q[3:7])
    q[3:7] = out
    return q


def test_stubby_rocked_onto_its_soles_front_edges_slips_nothing_while_the_ankle_path_grows(scene) -> None:
    m = scene.model
    d = mujoco.MjData(m)
    meter = SupportMeter(scene)
    feet = [(b, g) for b, g in meter._feet]
    q = scene.home_qpos.copy()
    q[2] -= 0.002
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_forward(m, d)
    # The soles' front bottom edge (the largest x of the feet's box corners, the lowest z), from MuJoCo's geoms.
    corners = []
    for _, g in feet:
        for gid in np.flatnonzero(g):
            half = m.geom_size[gid]
            for sx in (-1, 1):
                for sy in (-1, 1):
                    for sz in (-1, 1):
                        corners.append(d.geom_xpos[gid] + d.geom_xmat[gid].reshape(3, 3) @ (half * [sx, sy, sz]))
    corners = np.array(corners)
    axis_x, axis_z = corners[:, 0].max(), corners[:, 2].min()
    angles = np.r_[np.linspace(0.0, 0.25, 26), np.linspace(0.25, 0.0, 26)[1:]]  # onto the edges and back
    ankles = []
    for i, a in enumerate(angles):
        d.qpos[scene.robot_qadr] = _stubby_pitched(scene, a, axis_x, axis_z)
        mujoco.mj_forward(m, d)
        for _, g in feet:  # both soles touch the floor at every step (on their front edges when tipped)
            assert any(d.contact.dist[c] <= 0 and g[d.contact.geom[c]].any() for c in range(d.ncon))
        meter.update(d)
        ankles.append(d.xpos[[b for b, _ in feet], :2].copy())
        if i % 5 == 4:
            meter.end_frame()
    meter.end_frame()
    # The ankle's path by brute force, frame by frame (5 steps each; a frame's first move from the frame before's
    # last step), the larger foot per frame, as the meter defines it.
    ankles = np.array(ankles)
    moves = np.linalg.norm(np.diff(ankles, axis=0), axis=2)  # (steps - 1, 2 feet)
    want = sum(moves[max(lo - 1, 0): lo + 4].sum(axis=0).max() for lo in range(0, len(angles), 5))
    slide = sum(f.slide for f in meter.frames)
    slip = sum(f.slip for f in meter.frames)
    assert slide == pytest.approx(want, rel=1e-9) and slide > 0.03  # the ankle meter reads the swing, 8 cm up
    assert slip < 0.001  # the soles' contacts stay on the edge: no slip
    assert sum(f.steps for f in meter.frames) == 0


def test_the_frames_slip_is_the_larger_foots(scene, monkeypatch) -> None:  # noqa: ANN001
    meter = SupportMeter(scene)
    monkeypatch.setattr(meter._sole_slip, "end_frame",
                        lambda: FrameSlip(slip=(0.01, 0.03), steps=2, step_length=0.07, skims=3, skim_length=0.004))
    fs = meter.end_frame()
    assert fs.slip == 0.03 and fs.steps == 2 and fs.step_length == 0.07 and fs.skims == 3 and fs.skim_length == 0.004


def _frame(slide: float, slip: float, steps: int, length: float) -> FrameSupport:
    return FrameSupport(outside_mean=0.0, outside_peak=0.0, slide=slide, penetration=0.0, torque_ratio=0.0,
                        saturated=0.0, at_limit=0.0, slip=slip, steps=steps, step_length=length, skims=2 * steps,
                        skim_length=length / 10)


def test_the_contact_phase_counts_its_own_frames_only() -> None:
    frames = [(_frame(0.01, 0.002, 0, 0.0), True), (_frame(0.05, 0.04, 1, 0.06), False),
              (_frame(0.02, 0.001, 1, 0.03), True), (_frame(0.03, 0.03, 0, 0.0), False)]
    sim = SimpleNamespace(
        results=[SimpleNamespace(support=f, subgoals_now={"touch": on}) for f, on in frames],
        support=SimpleNamespace(mass=10.0, gravcomp_fraction=0.0),
        config=SimpleNamespace(gravity_compensation=False, stance=None, balance=None))
    out = support_summary(sim)  # type: ignore[arg-type]
    cp, ep = out["contact_phase"], out["episode"]
    assert cp["frames"] == 2
    assert cp["foot_slide_cm"] == pytest.approx(3.0) and ep["foot_slide_cm"] == pytest.approx(11.0)
    assert cp["foot_slip_cm"] == pytest.approx(0.3) and ep["foot_slip_cm"] == pytest.approx(7.3)
    assert cp["foot_steps"] == 1 and ep["foot_steps"] == 2
    assert cp["foot_step_cm"] == pytest.approx(3.0) and ep["foot_step_cm"] == pytest.approx(9.0)
    assert cp["foot_skims"] == 2 and ep["foot_skims"] == 4
    assert cp["foot_skim_cm"] == pytest.approx(0.3) and ep["foot_skim_cm"] == pytest.approx(0.9)


def test_the_demo_page_names_the_ankles_path_and_the_soles_slip_apart(tmp_path) -> None:  # noqa: ANN001
    from socialaff_sim.demo.pipeline import DemoConfig
    from socialaff_sim.report.demo_page import write_demo_page
    from test_physics_mode import _result

    cp = {"frames": 12, "released_frames": 9, "outside_support_mean": 0.0234, "outside_support_peak": 0.41,
          "foot_slide_cm": 3.25, "foot_drift_cm": 1.5, "torque_ratio_max": 0.97, "torso_tilt_deg_max": 6.2}
    config = DemoConfig(baselines=("promp",), video=False)
    old = write_demo_page(tmp_path, [_result({"mode": "m", "contact_phase": cp})], config).read_text()
    assert "3.2 cm (the ankle&#x27;s path)" in old and "slipped" not in old  # metrics made before the slip meter
    new = {**cp, "foot_slip_cm": 0.42, "foot_steps": 2, "foot_step_cm": 7.0, "foot_skims": 3, "foot_skim_cm": 0.9}
    page = write_demo_page(tmp_path, [_result({"mode": "m", "contact_phase": new})], config).read_text()
    assert ("slipped 0.4 cm on the floor (not the ankle&#x27;s path) besides 2 steps (7.0 cm) and 3 skims (0.9 cm, "
            "off the floor within 5 mm)") in page


class _PlainSlip:
    """The slip, steps and skims computed the plain way, contact by contact at every physics step (the module
    docstring's definitions, without the batching over a frame's steps)."""

    def __init__(self, meter: SupportMeter) -> None:
        self.m = meter.scene.model
        self.floor = meter.scene.floor_geom
        self.feet = [g for _, g in meter._feet]
        self.ankles = [b for b, _ in meter._feet]
        self.prev: list[list] = [[], []]  # per foot: its touching contacts at the last step (geom, point, x, R)
        self.gap: list = [None, None]  # per foot off the floor: [contacts, ankle xy, rise]
        self.frames: list[tuple] = []
        self._clear()

    def _clear(self) -> None:
        self.slip, self.steps, self.step_len, self.skims, self.skim_len = [0.0, 0.0], 0, 0.0, 0, 0.0

    @staticmethod
    def _carry(c, d) -> np.ndarray:  # noqa: ANN001
        g, p, x, R = c
        return d.xpos[g[1]] + d.xmat[g[1]].reshape(3, 3) @ (R.T @ (p - x))

    def update(self, d) -> None:  # noqa: ANN001
        now: list[list] = [[], []]
        for i in range(d.ncon):
            g1, g2 = (int(v) for v in d.contact.geom[i])
            other = g2 if g1 == self.floor else g1 if g2 == self.floor else -1
            for s in (0, 1):
                if other >= 0 and self.feet[s][other] and d.contact.dist[i] <= 0:
                    b = int(self.m.geom_bodyid[other])
                    now[s].append(((other, b), d.contact.pos[i].copy(), d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()))
        for s in (0, 1):
            touching = {c[0][0] for c in now[s]}
            kept = [c for c in self.prev[s] if c[0][0] in touching]
            if kept:
                self.slip[s] += float(np.mean([np.hypot(*(self._carry(c, d) - c[1])[:2]) for c in kept]))
            if now[s] and self.gap[s] is not None:  # back on the floor
                contacts, xy, rise = self.gap[s]
                if rise > 0.005:
                    self.steps += 1
                    self.step_len += float(np.hypot(*(d.xpos[self.ankles[s], :2] - xy)))
                else:
                    self.skims += 1
                    self.skim_len += float(np.mean([np.hypot(*(self._carry(c, d) - c[1])[:2]) for c in contacts]))
                self.gap[s] = None
            elif not now[s]:
                if self.prev[s]:  # just left the floor
                    self.gap[s] = [self.prev[s], self.ankle_xy[s], 0.0]
                if self.gap[s] is not None:
                    low = min(self._carry(c, d)[2] - c[1][2] for c in self.gap[s][0])
                    self.gap[s][2] = max(self.gap[s][2], low)
            self.prev[s] = now[s]
        self.ankle_xy = [d.xpos[b, :2].copy() for b in self.ankles]

    def end_frame(self) -> None:
        self.frames.append((max(self.slip), self.steps, self.step_len, self.skims, self.skim_len))
        self._clear()


def test_the_batched_meter_matches_the_plain_one_over_a_standing_episode(monkeypatch) -> None:  # noqa: ANN001
    # A standing hand-over replay (ground truth, Stubby): its walk-up steps and skims, its contact phase's slip,
    # contacts that come and go within frames and across them.
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    refs: dict[int, _PlainSlip] = {}
    reset, update, end_frame = SupportMeter.reset, SupportMeter.update, SupportMeter.end_frame

    def both_reset(self) -> None:  # noqa: ANN001
        reset(self)
        if hasattr(self, "_sole_slip"):
            refs[id(self)] = _PlainSlip(self)

    def both_update(self, d) -> None:  # noqa: ANN001
        update(self, d)
        refs[id(self)].update(d)

    def both_end(self):  # noqa: ANN001, ANN202
        refs[id(self)].end_frame()
        return end_frame(self)

    monkeypatch.setattr(SupportMeter, "reset", both_reset)
    monkeypatch.setattr(SupportMeter, "update", both_update)
    monkeypatch.setattr(SupportMeter, "end_frame", both_end)
    inter = generate_dataset(seed=0).of_label("hand_over")[3]
    sim = Simulator("ours", "hand_over", SimConfig.standing())
    run_episode(sim, GroundTruthSource(), inter)
    ref = refs[id(sim.support)]
    frames = [(f.slip, f.steps, f.step_length, f.skims, f.skim_length) for f in sim.support.frames]
    assert len(ref.frames) == len(frames) >= 30
    np.testing.assert_allclose(np.array(frames), np.array(ref.frames), rtol=1e-9, atol=1e-12)
    got = np.array(frames)
    assert got[:, 0].sum() > 0.01 and got[:, 1].sum() >= 1 and got[:, 3].sum() >= 1  # slip, steps and skims seen
