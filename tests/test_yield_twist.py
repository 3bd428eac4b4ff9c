"""``BalanceConfig.yield_twist``: the arms give way to a push across the robot before it twists the planted feet
(issue 25, the standing mode's feet)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.hand_yield import HandYield, feet_allowance, twist_allowance
from socialaff_sim.sim.sim_config import SimConfig
from socialaff_sim.sim.support_box import SupportBox

W = 446.0


BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))


def test_the_twist_allowance_is_the_force_whose_moment_about_the_middle_is_sigma_w(rng) -> None:
    for _ in range(200):
        mid, at = rng.normal(size=2), rng.normal(size=2)
        a = rng.uniform(0, 2 * np.pi)
        u = np.array([np.cos(a), np.sin(a)])
        sigma = rng.uniform(0.005, 0.05)
        f = twist_allowance(mid, u, at, W, sigma)
        moment = np.cross(np.append(at - mid, 0.0), np.append(f * u, 0.0))[2]  # independent: the 3-D cross product
        assert abs(moment) == pytest.approx(sigma * W, rel=1e-9)
    assert twist_allowance(np.zeros(2), np.array([1.0, 0.0]), np.array([0.5, 0.0]), W, 0.02) == float("inf")


def _sideways(scene, twist: float | None) -> HandYield:
    """Stubby's right hand pushed 25 N sideways (+y) at 0.35 m in front of its feet, 1 m up, for one update."""
    hy = HandYield(scene, 0.5, 50.0, 0.5, 0.0, twist)
    hy.force = np.array([[0.0, 0.0, 0.0], [0.0, 25.0, 0.0]])
    hy._height, hy._at = 1.0, np.array([0.35, 0.0])
    hy.update(0.004, BOX, np.zeros(2), 0.0, 0.01, W)
    return hy


def test_a_sideways_push_within_the_tipping_allowance_gives_only_beyond_the_twist(scene) -> None:
    tip = feet_allowance(BOX, np.array([0.0, 1.0]), np.zeros(2), 0.01, W, 1.0)
    assert 25.0 < 0.5 * tip  # the push does not tip the robot (31.2 N): without the option the arm holds
    assert not _sideways(scene, None).offset.any()
    # σ = 0.02 m: 8.9 N·m over a 0.35 m lever, 25.5 N; half of it (κ = 0.5) is 12.7 N, under the push: it gives
    hy = _sideways(scene, 0.02)
    allow = 0.02 * W / 0.35
    np.testing.assert_allclose(hy.offset[1], [0.0, 0.004 * (25.0 - 0.5 * allow) / 50.0], atol=1e-12)
    assert not hy.offset[0].any() and hy.yield_steps == 1
    # σ = 0.1 m: 127 N over the lever, more than the tipping allowance, which then decides: it holds
    assert not _sideways(scene, 0.1).offset.any()


def test_yield_twist_needs_the_hands_give_and_a_length() -> None:
    assert BalanceConfig(hand_yield=0.5, yield_twist=0.02).yield_twist == 0.02
    with pytest.raises(ConfigError, match="yield_twist"):
        BalanceConfig(yield_twist=0.02)
    with pytest.raises(ConfigError, match="yield_twist"):
        BalanceConfig(hand_yield=0.5, yield_twist=0.0)


def test_the_standing_mode_carries_the_twist_give_and_the_harness_none() -> None:
    # Adopted by the rule of docs/design.md §5 (run on instances 120-127); the harness has no balance controller.
    assert SimConfig.standing().balance.yield_twist == 0.02
    assert SimConfig.harness().balance is None and SimConfig().balance is None
