"""``BalanceConfig.hand_task_roll_free`` (sim/hand_task.py: hand_task_wanted): the hands' rows only for a robot whose
feet ``flat_roll_free`` frees (a leg of fewer than six joints): the decision on a model written out here (one
five-joint leg) and on Stubby (six and six), the settings checked, the controllers built with it (Stubby: no task;
the H1, skipped without ../shared/robots: the task), and a standing Stubby episode with it identical step by step to
one without ``flat_roll_free`` and ``hand_task``, while the same settings without the gate change it. And
``hand_task_yield``: the give's offset and rate added to the rows' target and velocity terms (by hand), passed by the
controller only with the option."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import shared_robot
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.flat_feet import roll_free_axes
from socialaff_sim.sim.hand_task import hand_task_wanted
from socialaff_sim.sim.simulator import SimConfig, Simulator
from test_flat_roll_free import _legs


def _paired(gate: bool, weight: float | None = 10.0) -> SimConfig:
    """``SimConfig.standing()`` with ``flat_roll_free``, ``hand_task`` = ``weight`` and the gate."""
    cfg = SimConfig.standing()
    return dataclasses.replace(cfg, balance=dataclasses.replace(
        cfg.balance, flat_roll_free=True, hand_task=weight, hand_task_roll_free=gate))


def test_the_gate_gives_the_task_to_a_robot_with_a_freed_foot_only(scene) -> None:
    m, root, left, right = _legs()  # left leg five joints, right six
    fw = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    five = roll_free_axes(m, [left, right], fw, root)
    six = roll_free_axes(m, [right, right], fw, root)  # (both feet on six-joint legs)
    assert hand_task_wanted(10.0, True, five)
    assert not hand_task_wanted(10.0, True, six)
    assert not hand_task_wanted(10.0, True, None)  # without flat_roll_free nothing is freed
    # Stubby's legs: six joints each, nothing freed, no task.
    feet = FeetOnFloor(scene, 0.0)
    assert not hand_task_wanted(10.0, True, roll_free_axes(scene.model, feet.bodies, feet.forward, scene.root_body))
    # Without the gate every robot gets it; without hand_task none does.
    assert hand_task_wanted(10.0, False, six) and hand_task_wanted(10.0, False, None)
    assert not hand_task_wanted(None, True, five) and not hand_task_wanted(None, False, five)


def test_settings_are_checked() -> None:
    for bad in (dict(hand_task_roll_free=True), dict(hand_task=10.0, hand_task_roll_free=True),
                dict(flat_roll_free=True, hand_task_roll_free=True)):
        with pytest.raises(ConfigError, match="hand_task_roll_free"):
            BalanceConfig(solver="qp", flat_feet=True, **bad)
    assert BalanceConfig(solver="qp", flat_feet=True, flat_roll_free=True, hand_task=10.0,
                         hand_task_roll_free=True).hand_task_roll_free
    assert not BalanceConfig().hand_task_roll_free


def _interaction(label: str, k: int = 1):  # noqa: ANN202
    return list(generate_dataset(0, SyntheticConfig(interactions=(label,), instances_per_interaction=k + 1)))[k]


def test_the_controllers_built_with_it_stubby_none_the_h1_the_task() -> None:
    inter = _interaction("shake_hands")
    for gate, has in ((True, False), (False, True)):
        bal = Simulator("ours", "shake_hands", _paired(gate))._get_stage(inter).stepper.balance
        assert (bal.hands is not None) is has
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal = Simulator(spec, "shake_hands", _paired(True))._get_stage(inter).stepper.balance
    assert bal.hands is not None and bal.hands.weight == 10.0
    assert any(a is not None for a in bal._roll_free)


def _episode(cfg: SimConfig, inter) -> list[np.ndarray]:  # noqa: ANN001
    """The robot's and the scene's state after every frame of a standing Stubby episode."""
    sim = Simulator("ours", inter.label, cfg)
    states: list[np.ndarray] = []
    run_episode(sim, GroundTruthSource(), inter,
                on_frame=lambda s, r, e: states.append(np.concatenate([s.data.qpos, s.data.qvel, s.data.ctrl])))
    return states


def test_stubby_runs_bit_for_bit_as_without_either_option() -> None:
    inter = _interaction("high_five")
    base = _episode(SimConfig.standing(), inter)
    gated = _episode(_paired(True), inter)
    assert len(base) == len(gated) > 10
    for a, b in zip(base, gated, strict=True):
        np.testing.assert_array_equal(a, b)
    # the same settings without the gate give Stubby the hands' rows, which change its motion (so the check can fail)
    ungated = _episode(_paired(False), inter)
    assert any(not np.array_equal(a, b) for a, b in zip(base, ungated))


# -- hand_task_yield: the task's target moved with the hands' give ---------------------------------------------------

def test_the_give_moves_the_target_and_its_velocity(scene) -> None:
    from socialaff_sim.sim.hand_task import HandTask
    from test_hand_task import _moving

    m = scene.model
    d = _moving(scene, np.random.default_rng(5))
    va = np.asarray(scene.robot_vadr)
    task = HandTask(scene, 1.0, 8.0)
    task.targets = task.positions(d) + np.array([[0.05, -0.02, 0.1], [-0.04, 0.03, 0.02]])
    offset = np.array([[0.03, -0.01], [0.0, 0.02]])
    rate = np.array([[0.2, 0.1], [-0.3, 0.0]])
    plain = task.tasks(m, d, va, None)
    given = task.tasks(m, d, va, None, (offset, rate))
    zero = task.tasks(m, d, va, None, (np.zeros((2, 2)), np.zeros((2, 2))))
    for s in (0, 1):
        np.testing.assert_array_equal(given[s][0], plain[s][0])
        # b = ω² (x* + o − x) + 2 ω (ȯ − ẋ) − J̇ q̇: by the offset's and rate's terms alone, vertical row untouched
        want = np.r_[64.0 * offset[s] + 16.0 * rate[s], 0.0]
        np.testing.assert_allclose(given[s][1] - plain[s][1], want, atol=1e-12)
        np.testing.assert_array_equal(zero[s][1], plain[s][1])  # no give: the plan's wrist, bit for bit


def test_hand_task_yield_needs_the_task_and_the_give() -> None:
    for bad in (dict(hand_task_yield=True), dict(hand_task=10.0, hand_task_yield=True),
                dict(hand_yield=0.5, hand_task_yield=True)):
        with pytest.raises(ConfigError, match="hand_task_yield"):
            BalanceConfig(solver="qp", flat_feet=True, **bad)
    assert BalanceConfig(hand_task=10.0, hand_yield=0.5, hand_task_yield=True).hand_task_yield
    assert not BalanceConfig().hand_task_yield and not SimConfig.standing().balance.hand_task_yield


@pytest.mark.parametrize("follow", [False, True])
def test_the_controller_passes_the_give_only_with_the_option(follow: bool) -> None:
    cfg = SimConfig.standing()  # (hand_yield on)
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, hand_task=10.0, hand_task_yield=follow,
                                                                     hand_task_roll_free=False))  # (Stubby: ungated)
    inter = _interaction("pull_up")
    sim = Simulator("ours", "pull_up", cfg)
    bal = sim._get_stage(inter).stepper.balance
    seen: list[bool] = []
    tasks = bal.hands.tasks

    def spy(m, d, va, touched, give=None):  # noqa: ANN001, ANN202
        seen.append(give is not None and give[0] is bal.hand_yield.offset and give[1] is bal.hand_yield.rate)
        return tasks(m, d, va, touched, give)

    bal.hands.tasks = spy
    run_episode(sim, GroundTruthSource(), inter)
    assert len(seen) > 100 and all(x is follow for x in seen)
