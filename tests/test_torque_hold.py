"""The balance controller's torques solved at one driven step in k (``BalanceConfig.qp_every``, ``hold_gain``,
``hold_near``, ``hold_touch``;
sim/torque_hold.py): the held torques against the formula written out, which steps solve and which hold (the
count, a switch of the harness, a step not driven), the controller's calls of its solve, and the option off."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim import balance_control
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.external_force import Contacts, ExternalForces
from socialaff_sim.sim.scene import Scene, build_scene
from socialaff_sim.sim.torque_hold import TorqueHold
from test_balance_control import LAYOUT, _stand


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(load_robot("ours"), LAYOUT, harness_time_constant=0.02)


def test_held_torques_are_the_solve_plus_the_joints_pd_on_the_errors_change(rng) -> None:
    hold = TorqueHold(3, 0.5, 20.0)
    tau, inertia, e0, ed0 = rng.normal(size=5), rng.uniform(0.01, 1.0, size=5), rng.normal(size=5), rng.normal(size=5)
    hold.store(tau, inertia, e0, ed0, released=True)
    tau[:] = 0.0  # the hold kept its own copy
    e, ed = rng.normal(size=5), rng.normal(size=5)
    want = []
    for i in range(5):  # entry by entry: τ_s + g_h M_ii (ω² Δe + 2ω Δė)
        want.append(float(hold._tau[i]) + 0.5 * float(inertia[i]) * (400.0 * (e[i] - e0[i]) + 40.0 * (ed[i] - ed0[i])))
    np.testing.assert_allclose(hold.torques(e, ed), want, rtol=1e-12, atol=1e-12)


def test_a_zero_gain_holds_the_solved_torques_as_they_are(rng) -> None:
    hold = TorqueHold(2, 0.0, 20.0)
    tau = rng.normal(size=4)
    hold.store(tau, np.ones(4), np.zeros(4), np.zeros(4), released=False)
    np.testing.assert_array_equal(hold.torques(rng.normal(size=4), rng.normal(size=4)), tau)


def test_a_hold_lasts_k_minus_one_steps_and_ends_on_a_switch_of_the_harness_or_a_drop() -> None:
    hold = TorqueHold(3, 1.0, 20.0)
    z = np.zeros(2)
    assert hold.due(False) and hold.due(True)  # nothing held yet
    hold.store(z, z, z, z, released=True)
    assert not hold.due(True)
    hold.torques(z, z)
    assert not hold.due(True)
    hold.torques(z, z)
    assert hold.due(True)  # two held, the third solves
    hold.store(z, z, z, z, released=True)
    assert hold.due(False)  # caught since the solve: solve again
    hold.drop()
    assert hold.due(True)


@pytest.mark.parametrize("kw", [{"qp_every": 0}, {"qp_every": 2.0}, {"hold_gain": -0.1}, {"hold_near": -0.01}])
def test_the_rate_fields_reject_bad_values(kw) -> None:
    with pytest.raises(ConfigError, match="BalanceConfig"):
        BalanceConfig(**kw)


def _counted(monkeypatch) -> list[int]:
    calls: list[int] = []
    real = balance_control.BalanceController._torques

    def counted(self, *args, **kwargs):
        calls.append(self.steps)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(balance_control.BalanceController, "_torques", counted)
    return calls


def test_the_controller_solves_every_driven_step_with_the_option_off(scene, monkeypatch) -> None:
    calls = _counted(monkeypatch)
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp"), 0.3)
    assert ctl.hold is None and ctl.held_steps == 0
    assert len(calls) == ctl.active_steps > 0


def test_the_controller_solves_one_driven_step_in_k_and_holds_the_rest(scene, monkeypatch) -> None:
    calls = _counted(monkeypatch)
    ctl, d, _ = _stand(scene, BalanceConfig(solver="qp", qp_every=3), 0.5)
    assert ctl.active_steps > 30 and ctl.harness.released_steps > 0
    assert len(calls) + ctl.held_steps == ctl.active_steps
    # the release (a switch of the harness) may start a new count; otherwise every third driven step solves
    assert len(calls) <= ctl.active_steps // 3 + 3 and ctl.held_steps >= 2 * (ctl.active_steps // 3) - 4
    assert max(np.diff(calls)) <= 3  # never more than two held in a row
    assert ctl.attitude.tilt(d) <= 2.0  # and it still stands upright


def test_held_steps_give_the_servos_the_held_torques(scene, monkeypatch) -> None:
    # With a zero gain, every held step's actuators get the torques of the solve just before it, bit for bit.
    events: list[tuple[str, np.ndarray]] = []
    real = balance_control.BalanceController._torques

    def keep(self, *args, **kwargs):
        tau = real(self, *args, **kwargs)
        events.append(("solve", tau.copy()))
        return tau

    monkeypatch.setattr(balance_control.BalanceController, "_torques", keep)
    real_torques = TorqueHold.torques

    def spy(self, e, ed):
        out = real_torques(self, e, ed)
        events.append(("hold", out.copy()))
        return out

    monkeypatch.setattr(TorqueHold, "torques", spy)
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", qp_every=2, hold_gain=0.0), 0.3)
    held = [i for i, (kind, _) in enumerate(events) if kind == "hold"]
    assert ctl.held_steps == len(held) > 10
    for i in held:
        assert events[i - 1][0] == "solve"  # k = 2: one held step after each solve
        np.testing.assert_array_equal(events[i][1], events[i - 1][1])
    assert not all(np.array_equal(events[i][1], events[i - 2][1]) for i in held if i >= 2)  # the solves do change


def test_nothing_is_held_after_a_solve_with_an_arm_near_the_body(scene) -> None:
    # An arm within hold_near of the body (everything within reach counts at 5 m): every driven step solves.
    base = dict(solver="qp", qp_every=2, self_clearance=0.01, clearance_detection=5.0)
    ctl, _, _ = _stand(scene, BalanceConfig(**base, hold_near=5.0), 0.3)
    assert ctl.active_steps > 10 and ctl.clearance_steps == ctl.active_steps and ctl.held_steps == 0
    # The same rows, none within hold_near = 0: the hold works as without them.
    ctl, _, _ = _stand(scene, BalanceConfig(**base, hold_near=0.0), 0.3)
    assert ctl.clearance_steps > 0 and ctl.held_steps >= ctl.active_steps // 2 - 2


def test_with_hold_touch_nothing_is_held_while_anything_but_the_floor_touches_the_robot(scene, monkeypatch) -> None:
    touched = Contacts(np.zeros((1, 3)), np.zeros((1, 3)), np.array([0]), np.array([1]))
    monkeypatch.setattr(ExternalForces, "contacts", lambda self, m, d: touched)  # one contact at every step
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", qp_every=3, hold_touch=True), 0.3)
    assert ctl.active_steps > 10 and ctl.held_steps == 0
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", qp_every=3), 0.3)  # the same contact, hold_touch off
    assert ctl.held_steps >= 2 * (ctl.active_steps // 3) - 4
    monkeypatch.undo()  # nothing touches: the hold as without hold_touch
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", qp_every=3, hold_touch=True), 0.3)
    assert ctl.held_steps >= 2 * (ctl.active_steps // 3) - 4
