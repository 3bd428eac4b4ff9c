"""``BalanceConfig.touch_friction``: the balance QP's friction cones narrowed once an arm has touched the person or
the object (docs/design.md §5, issue 25, session 34, wip/pullslip)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.simulator import SimConfig

from test_balance_control import standing_far


def _run(scene: Scene, ctl: BalanceController, d: mujoco.MjData, q: np.ndarray, ctrl0: np.ndarray, steps: int) -> None:
    m = scene.model
    for k in range(steps):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))


def _edge_ratio(edges: np.ndarray) -> np.ndarray:
    """Each cone edge's tangential over normal part on the level floor (the world's z is the floor's normal), worked
    out from the edges' world components, not from the cone's construction."""
    return np.hypot(edges[:, 0, :], edges[:, 1, :]) / edges[:, 2, :]


def test_touch_friction_is_off_by_default_and_checked() -> None:
    assert BalanceConfig().touch_friction is None
    assert SimConfig.standing().balance.touch_friction == 0.35  # rule #47 (docs/design.md §5)
    base = SimConfig.standing().balance
    dataclasses.replace(base, touch_friction=0.35)  # valid: the standing mode has the touch latch
    for bad in (0.0, -0.2):
        with pytest.raises(ConfigError, match="touch_friction"):
            dataclasses.replace(base, touch_friction=bad)
    with pytest.raises(ConfigError, match="touch_friction"):  # no latch without the arms' compensation
        dataclasses.replace(base, touch_friction=0.35, arm_compensation=None, compensation_gate=None)
    with pytest.raises(ConfigError, match="touch_friction"):  # nor without its gate
        dataclasses.replace(base, touch_friction=0.35, compensation_gate=None)


@pytest.mark.parametrize("option", [None, 0.3])
def test_the_cones_narrow_to_touch_friction_only_after_a_touch(scene: Scene, option: float | None) -> None:
    # Before any touch the cones are friction's (0.7); once the latch says an arm has touched, touch_friction's
    # (0.3), and they stay so; without the option the touch changes nothing. Inverting the decision (the touch's
    # cones before the touch, or friction's after it) fails the first or the second check.
    config = dataclasses.replace(SimConfig.standing().balance, touch_friction=option)
    d, q, ctl, ctrl0 = standing_far(scene, config)
    _run(scene, ctl, d, q, ctrl0, 75)  # released after 0.1 s: the QP solves
    assert ctl.active_steps > 0
    before = _edge_ratio(ctl._edges[1])
    assert before.size and np.allclose(before, 0.7, atol=1e-9)
    assert ctl.compensation is not None and not ctl.compensation.touched.any()
    ctl.compensation.touched[:] = [False, True]  # the right arm touched the person (the episode's latch)
    _run(scene, ctl, d, q, ctrl0, 25)
    after = _edge_ratio(ctl._edges[1])
    assert after.size and np.allclose(after, 0.7 if option is None else option, atol=1e-9)
    # the edges are still unit forces whose normal part is 1/sqrt(1 + mu^2) (an independent figure of the cone)
    mu = 0.7 if option is None else option
    np.testing.assert_allclose(np.linalg.norm(ctl._edges[1], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(ctl._edges[1][:, 2, :], 1.0 / np.sqrt(1.0 + mu * mu), atol=1e-9)
