"""The balance controller's per-step shortcuts (issue 25, the standing mode's CPU cost): each gives what it replaces,
bit for bit, against an independent reference — the actuators' limit table against MuJoCo's own clipping, the centre-of-pressure rows against an entry-by-entry construction and against the centres of
pressure themselves, the step's contacts read once and handed to every part that folds them in, and the feet's
rows built in reused room."""

from __future__ import annotations

import mujoco
import numpy as np

from socialaff_sim.sim import arm_compensation, hand_yield
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_qp import ActuatorLimits, cop_rows
from socialaff_sim.sim.external_force import ExternalForces, FilteredExternal
from socialaff_sim.sim.flat_feet import foot_rows
from socialaff_sim.sim.scene import Scene
from test_balance_control import _stand
from test_balance_qp_rows import moving_home
from test_balance_qp import ACTUATED


UNLIMITED = """
<mujoco>
  <worldbody>
    <body><joint name="a" axis="0 1 0"/><geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator><motor joint="a" gear="1"/></actuator>
</mujoco>
"""


def _clipped(m: mujoco.MjModel, d: mujoco.MjData, act_ids: np.ndarray) -> np.ndarray:
    """(A, 2) what MuJoCo delivers to each actuated joint (one actuator, gear 1, per joint) at ``d``'s state with
    the actuators' controls far past each end."""
    dofs = m.jnt_dofadr[m.actuator_trnid[act_ids, 0]]
    out = np.empty((len(act_ids), 2))
    for end, col in ((-1e6, 0), (1e6, 1)):
        d.ctrl[act_ids] = end
        mujoco.mj_forward(m, d)
        out[:, col] = d.qfrc_actuator[dofs]
    return out


def test_the_actuator_limit_table_is_mujocos_clipping(rng, scene: Scene) -> None:
    m = mujoco.MjModel.from_xml_string(ACTUATED)
    d = mujoco.MjData(m)
    table = ActuatorLimits(m, np.arange(3))
    for _ in range(20):
        d.qpos[:] = rng.uniform(-1.0, 1.0, size=3)
        d.qvel[:] = rng.normal(size=3)
        lim = table(d.qpos.copy(), d.qvel.copy())
        np.testing.assert_allclose(_clipped(m, d, np.arange(3)), lim, atol=1e-9)  # independent: MuJoCo's own
    free = mujoco.MjModel.from_xml_string(UNLIMITED)  # nothing limits it: ±inf
    np.testing.assert_array_equal(ActuatorLimits(free, np.arange(1))(np.zeros(1), np.ones(1)), [[-np.inf, np.inf]])
    # Stubby's servos (control ranges and force ranges) at random states of their joints: MuJoCo's own figures
    sm = scene.model
    ids = np.asarray(scene.act_ids, dtype=np.int64)
    joints = sm.actuator_trnid[ids, 0]
    table = ActuatorLimits(sm, ids)
    sd = mujoco.MjData(sm)
    for _ in range(20):
        q = rng.uniform(-1.0, 1.0, size=len(ids))
        v = rng.normal(size=len(ids))
        sd.qpos[sm.jnt_qposadr[joints]] = q
        sd.qvel[sm.jnt_dofadr[joints]] = v
        np.testing.assert_allclose(_clipped(sm, sd, ids), table(q, v), atol=1e-9)


def _cop_rows_reference(points, edges, foot, axes, bounds) -> np.ndarray:
    """Entry by entry: rows (foot s, axis a, lower then upper side), column 4p + k: f_z of edge k at point p times
    its lever arm, for p of foot s; 0 elsewhere (the points' coordinates along the axes as the rows take them)."""
    P = len(points)
    coord = points[:, :2] @ axes.T
    rows = []
    for s in range(len(bounds)):
        if not (foot == s).any():
            continue
        for a in range(2):
            for side in (0, 1):
                row = np.zeros(4 * P)
                for p in range(P):
                    if foot[p] != s:
                        continue
                    r = coord[p, a]
                    arm = r - bounds[s, a, 0] if side == 0 else bounds[s, a, 1] - r
                    for k in range(4):
                        row[4 * p + k] = edges[p, 2, k] * arm
                rows.append(row)
    return np.array(rows) if rows else np.zeros((0, 4 * P))


def test_cop_rows_against_their_entries_and_the_centres_of_pressure(rng) -> None:
    for trial in range(40):
        P = int(rng.integers(1, 10))
        points = np.column_stack([rng.uniform(-0.2, 0.2, size=(P, 2)), np.zeros(P)])
        edges = rng.uniform(0.1, 1.0, size=(P, 3, 4))
        foot = rng.integers(-1, 2, size=P)  # −1: a point left unbounded
        t = rng.uniform(0.0, np.pi)
        axes = np.array([[np.cos(t), np.sin(t)], [-np.sin(t), np.cos(t)]])
        lo = rng.uniform(-0.15, 0.0, size=(2, 2))
        bounds = np.stack([lo, lo + rng.uniform(0.01, 0.2, size=(2, 2))], axis=2)  # (F, 2, 2)
        C = cop_rows(points, edges, foot, axes, bounds)
        ref = _cop_rows_reference(points, edges, foot, axes, bounds)
        assert C.shape == ref.shape
        np.testing.assert_array_equal(C, ref)
        # and what they mean: C β ≥ 0 iff every foot carrying weight has its centre of pressure in its bounds
        beta = rng.uniform(0.0, 1.0, size=(P, 4))
        inside = True
        for s in range(len(bounds)):
            mine = foot == s
            fz = (edges[mine, 2, :] * beta[mine]).sum(axis=1)
            if not mine.any() or fz.sum() <= 0:
                continue
            cop = (fz[:, None] * (points[mine, :2] @ axes.T)).sum(axis=0) / fz.sum()
            inside &= bool(np.all(cop >= bounds[s, :, 0] - 1e-12) and np.all(cop <= bounds[s, :, 1] + 1e-12))
        assert bool(np.all(C @ beta.ravel() >= -1e-12)) == inside, trial


def test_the_controller_reads_the_steps_contacts_once_and_hands_them_to_every_part(scene: Scene, monkeypatch) -> None:
    """With the hands' give, the arms' compensation and the external forces all on, each physics step the robot
    stands reads :meth:`ExternalForces.contacts` once, and all three parts fold in that one reading."""
    reads: list[object] = []
    real = ExternalForces.contacts

    def counted(self, m, d):
        out = real(self, m, d)
        reads.append(out)
        return out

    monkeypatch.setattr(ExternalForces, "contacts", counted)
    got: dict[str, list[object]] = {"yield": [], "compensation": [], "external": []}

    for name, cls, attr in (("yield", hand_yield.HandYield, "measure"),
                            ("compensation", arm_compensation.ArmCompensation, "measure")):
        orig = getattr(cls, attr)

        def spy(self, m, contacts, *args, _orig=orig, _name=name):  # (the hands' give also takes d, carried)
            got[_name].append(contacts)
            return _orig(self, m, contacts, *args)

        monkeypatch.setattr(cls, attr, spy)
    orig_ext = FilteredExternal.measure

    def spy_ext(self, m, d, contacts):
        got["external"].append(contacts)
        return orig_ext(self, m, d, contacts)

    monkeypatch.setattr(FilteredExternal, "measure", spy_ext)
    cfg = BalanceConfig(solver="qp", hand_yield=0.5, arm_compensation=1.0, external_forces=True)
    ctl, _, _ = _stand(scene, cfg, 0.2)
    assert ctl.steps == 50 and len(reads) > 0
    assert len(reads) <= ctl.steps  # at most one reading per physics step
    for name in got:  # every part got each step's one reading, the very same object
        assert len(got[name]) == len(reads), name
        assert all(a is b for a, b in zip(got[name], reads, strict=True)), name


def test_foot_rows_in_reused_room_are_the_same_bits_whatever_the_room_held(rng, scene: Scene) -> None:
    """The balance controller hands :func:`foot_rows` the same two arrays every step; MuJoCo overwrites them whole,
    so rows built in room full of garbage equal those built in fresh room, bit for bit."""
    m, d, vadr = moving_home(rng, scene)
    room = (np.full((6, m.nv), np.nan), np.full((6, m.nv), 1e300))
    for body in (int(m.site_bodyid[scene.frame_ids[3]]) if scene.frame_kinds[3] == "site" else int(scene.frame_ids[3]),
                 int(scene.root_body)):
        goal = d.xpos[body] + rng.normal(scale=0.01, size=3)
        fresh = foot_rows(m, d, body, vadr, goal, np.eye(3), 100.0, 20.0)
        reused = foot_rows(m, d, body, vadr, goal, np.eye(3), 100.0, 20.0, room)
        np.testing.assert_array_equal(fresh[0], reused[0])
        np.testing.assert_array_equal(fresh[1], reused[1])
        assert np.isfinite(reused[0]).all() and np.isfinite(reused[1]).all()
