"""The contact completion's reach gate measured from the plan's shoulders (``ContactCompletionConfig.planned_shoulder``).

In the simulator, at a recorded high five's strike: the IK's latest solution is moved by a few centimetres along
the line from the physical shoulder to the completed wrist target, so that the plan's shoulder and the physical one
stand at different distances from that target. The arm's length is then set so that the target lies ε inside or ε
beyond the gate's far edge (ρ·arm + b) as measured from the plan's shoulder, and the completion's weight (``ramp``
0: the weight is the gate) is checked against the gate computed by hand from each shoulder.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import SimulationError
from socialaff_sim.retarget.contact_completion import ContactCompletionConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

EPS = 0.005  # m: inside / beyond the gate's edge
SHIFT = 0.03  # m: how far the plan is moved from where the robot is


def _gate(beyond: float, band: float) -> float:
    """The reach gate written out: 1 within the reach, 0 at ``band`` beyond it, 3u² − 2u³ between (u = (b − beyond)/b)."""
    u = min(max((band - beyond) / band, 0.0), 1.0)
    return 3 * u * u - 2 * u ** 3


@pytest.fixture(scope="module")
def strike():  # noqa: ANN201
    inter = list(generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=8)))[6]
    t = int(np.flatnonzero(np.asarray(inter.subevents) == inter.subevent_names.index("strike"))[0])
    return inter, t


def _at_strike(strike, planned: bool, sign: float):  # noqa: ANN001, ANN202
    """A harnessed Stubby replaying the recorded agent 1 to the frame before the strike, its IK solution then moved
    by ``sign`` × SHIFT along the physical shoulder → target line; returns the simulator, the frame, the hand side,
    the target (world), the plan's and the physical shoulder of that side."""
    inter, t = strike
    cc = dataclasses.replace(ContactCompletionConfig(), ramp=0.0, planned_shoulder=planned)
    # The robot's right hand only (the left one's shoulder stands elsewhere: a gate closing on the right hand would
    # hand the strike to the left one, another decision than the one tested here).
    task = load_task("high_five")
    task = dataclasses.replace(task, subgoals=tuple(dataclasses.replace(g, robot="right_hand") for g in task.subgoals))
    sim = Simulator("ours", task, dataclasses.replace(SimConfig(), contact_completion=cc))
    keys = inter.key_joints()[:, 1]
    sim.reset(inter)
    sim.settle(sim.retarget(keys[0], frame=0))
    while sim.frame < t - 1:
        sim.step(sim.retarget(keys[sim.frame + 1]))
    ft = sim._targets
    ft.arm = 100.0  # everything in reach: β = 1, the output is the completed target itself
    sim.retarget(keys[t], frame=t, contact=True, contact_inside=True)
    side = 1
    assert ft.completion.weight.tolist() == [0.0, 1.0]
    physical = np.array(sim.data.xpos[sim.scene.limb_body_ids[side]])
    ik = sim._stage.ik
    q = ik.configuration.q.copy()
    first = sim.frame_R.to_world(sim.retarget(keys[t], frame=t, contact=True, contact_inside=True))[1 + side]
    u = (first - physical) / np.linalg.norm(first - physical)
    q[:3] += sign * SHIFT * u
    ik.configuration.update(q)
    target = sim.frame_R.to_world(sim.retarget(keys[t], frame=t, contact=True, contact_inside=True))[1 + side]
    assert ft.completion.weight[side] == 1.0
    # The plan's shoulder, from the IK model's own forward kinematics (a fresh MjData at the moved q).
    m = sim._stage.ik_scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    plan = np.array(d.xpos[sim._stage.ik_scene.limb_body_ids[side]])
    return sim, t, side, keys[t], target, plan, physical


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_gate_opens_and_closes_at_its_edge_measured_from_the_chosen_shoulder(strike, sign: float) -> None:  # noqa: ANN001
    band = ContactCompletionConfig().reach_band
    for planned in (True, False):
        sim, t, side, keys, target, plan, physical = _at_strike(strike, planned, sign)
        d_plan, d_phys = float(np.linalg.norm(target - plan)), float(np.linalg.norm(target - physical))
        # Moved toward the target the plan's shoulder is nearer than the physical one, moved away farther.
        assert sign * (d_phys - d_plan) > 2 * EPS
        ft = sim._targets
        for edge in (-EPS, EPS):  # the target ε inside, then ε beyond, the gate's far edge from the plan's shoulder
            ft.arm = d_plan - band - edge  # ρ = 1
            sim.retarget(keys, frame=t, contact=True, contact_inside=True)
            d = d_plan if planned else d_phys
            expected = _gate(d - ft.arm, band)
            assert ft.completion.weight[side] == pytest.approx(expected, abs=1e-9)
            if planned:
                assert (expected > 0) == (edge < 0)  # open just inside the edge, shut just beyond it
                assert expected == pytest.approx(_gate(band + edge, band), abs=1e-12)


def test_the_planned_shoulders_are_the_ik_solutions_and_need_the_ik_bodies(strike) -> None:  # noqa: ANN001
    sim, *_ = _at_strike(strike, True, 1.0)
    ft = sim._targets
    ik_scene = sim._stage.ik_scene
    m = ik_scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = sim._stage.ik.configuration.q
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(ft.planned_shoulders(), d.xpos[ik_scene.limb_body_ids[:2]], atol=1e-12)
    ft.ik_shoulders = None
    with pytest.raises(SimulationError, match="planned_shoulder"):
        ft.planned_shoulders()
