"""The caught robot's harness over its feet as they stand (BalanceConfig(catch_follow_feet=True)): the planted feet's
offset (numerics against a hand computation; only planted feet count; zero with none), the anchor's shift (only with
the option and only while the harness holds a robot it has caught; horizontal only; applied before the catch's
blend), the default off, and the simulator setting the offset on a standing Stubby pull-up only with the option."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.harness_release import HarnessRelease, planted_offset
from socialaff_sim.sim.simulator import SimConfig

PHYS = np.array([[0.10, 0.12, 0.08], [-0.02, -0.11, 0.09]])
TARG = np.array([[0.16, 0.10, 0.08], [0.30, -0.10, 0.08]])


@pytest.mark.parametrize(("standing", "expected"), [
    ((True, True), [((0.10 - 0.16) + (-0.02 - 0.30)) / 2, ((0.12 - 0.10) + (-0.11 + 0.10)) / 2]),
    ((True, False), [-0.06, 0.02]),
    ((False, True), [-0.32, -0.01]),
    ((False, False), [0.0, 0.0])])
def test_the_offset_is_the_planted_feet_mean(standing, expected) -> None:  # noqa: ANN001
    assert np.allclose(planted_offset(PHYS, TARG, standing), expected, atol=1e-12)


def _harness(on: bool, catches: int, released: bool) -> HarnessRelease:
    h = HarnessRelease.__new__(HarnessRelease)  # the anchor's arithmetic only: no scene
    h.config = BalanceConfig(catch_follow_feet=0.3 if on else None)
    h.follow = h.config.catch_follow_feet
    h._mocap, h.catches, h.released, h._caught = 0, catches, released, None
    h.feet_offset = np.array([-0.05, 0.02])
    return h


@pytest.mark.parametrize(("on", "catches", "released", "shifted"), [
    (True, 1, False, True), (False, 1, False, False), (True, 0, False, False), (True, 1, True, False)])
def test_the_anchor_is_shifted_only_while_caught_with_the_option(on, catches, released, shifted) -> None:  # noqa: ANN001
    h = _harness(on, catches, released)
    d = SimpleNamespace(mocap_pos=np.array([[1.0, 2.0, 0.9]]), mocap_quat=np.array([[1.0, 0.0, 0.0, 0.0]]))
    h.blend_anchor(SimpleNamespace(opt=SimpleNamespace(timestep=0.002)), d)
    assert np.allclose(d.mocap_pos[0], [0.95, 2.02, 0.9] if shifted else [1.0, 2.0, 0.9])


def test_the_shift_is_blended_from_the_catch() -> None:
    h = _harness(True, 1, False)
    h._caught = (np.array([0.0, 0.0, 0.9]), np.array([1.0, 0.0, 0.0, 0.0]), 0.15)  # half way through the 0.3 s blend
    d = SimpleNamespace(mocap_pos=np.array([[1.0, 2.0, 0.9]]), mocap_quat=np.array([[1.0, 0.0, 0.0, 0.0]]))
    h.blend_anchor(SimpleNamespace(opt=SimpleNamespace(timestep=0.002)), d)
    assert np.allclose(d.mocap_pos[0], [0.5 * 0.95, 0.5 * 2.02, 0.9])


@pytest.mark.parametrize(("gated", "chair", "kept"), [(True, True, True), (True, False, False), (False, False, True),
                                                      (False, True, True)])
def test_the_chair_gate(gated: bool, chair: bool, kept: bool) -> None:
    h = HarnessRelease.__new__(HarnessRelease)
    h.config = BalanceConfig(catch_follow_feet=0.3, catch_follow_chair=gated)
    h.gate_follow(chair)
    assert h.follow == (0.3 if kept else None)


def test_off_by_default_on_in_the_standing_mode_and_checked() -> None:
    assert BalanceConfig().catch_follow_feet is None and SimConfig().balance is None  # off but in the standing mode
    assert (SimConfig.standing().balance.catch_follow_feet, SimConfig.standing().balance.catch_follow_chair) == (
        0.3, True)  # rule #60 (session 36)
    with pytest.raises(ConfigError, match="catch_follow_feet"):
        BalanceConfig(catch_follow_feet=-0.01)
    assert BalanceConfig(catch_follow_feet=0.0).catch_follow_feet == 0.0
    with pytest.raises(ConfigError, match="catch_follow_chair"):
        BalanceConfig(catch_follow_chair=True)
    assert not BalanceConfig().catch_follow_chair


def test_the_simulator_sets_the_offset_only_with_the_option_and_near_a_meeting() -> None:
    """A standing Stubby pull-up (spent pull_up_561, caught near the meeting): the offset set (non-zero) at some frame
    only with the option on, and zero in every frame whose last frame's gaps all exceed d_m."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=562)).by_id("pull_up_561")
    base = SimConfig.standing()
    seen = {}
    for d_m in (None, 0.3):
        cfg = dataclasses.replace(base, balance=dataclasses.replace(base.balance, catch_follow_feet=d_m,
                                                                    catch_follow_chair=d_m is not None))
        rows: list[tuple[bool, float]] = []
        last: list = [None]

        def hook(s, r, e) -> None:  # noqa: ANN001
            if r is None:
                return
            prev = last[0]
            near = prev is not None and any(g is not None and g <= 0.3 for g in prev.subgoal_gaps.values())
            rows.append((near, float(np.linalg.norm(s._stage.stepper.balance.harness.feet_offset))))
            last[0] = r
        run_episode(Simulator("ours", inter.label, cfg), GroundTruthSource(), inter, on_frame=hook)
        seen[d_m] = rows
    assert seen[None] and max(n for _, n in seen[None]) == 0.0
    assert max(n for _, n in seen[0.3]) > 0.005
    assert any(not near for near, _ in seen[0.3]) and all(n == 0.0 for near, n in seen[0.3] if not near)


def test_the_simulator_drops_it_in_a_task_without_a_chair() -> None:
    """A standing Stubby handshake (spent shake_hands_675, caught near its meeting; lost by the ungated option): with
    the chair gate the harness's ``follow`` is ``None`` and the offset stays zero; without the gate it is set."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=676)).by_id("shake_hands_675")
    base = SimConfig.standing()
    for gated in (True, False):
        cfg = dataclasses.replace(base, balance=dataclasses.replace(base.balance, catch_follow_feet=0.3,
                                                                    catch_follow_chair=gated))
        norms: list[float] = []
        follow: list = []

        def hook(s, r, e) -> None:  # noqa: ANN001
            h = s._stage.stepper.balance.harness
            norms.append(float(np.linalg.norm(h.feet_offset)))
            follow.append(h.follow)
        run_episode(Simulator("ours", inter.label, cfg), GroundTruthSource(), inter, on_frame=hook)
        if gated:
            assert set(follow) == {None} and max(norms) == 0.0
        else:
            assert set(follow) == {0.3} and max(norms) > 0.005
