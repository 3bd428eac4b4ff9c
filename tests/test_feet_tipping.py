"""The standing mode's planted feet tipping onto their soles' edges (issue 25, session 32): each foot's centre of
pressure kept away from its sole's edges. ``BalanceConfig.cop_kern`` (an option, off): the intervals against a
construction by hand, the choice κ = 0.5 against a rigid sole on four equal corner springs solved as a linear system
(all four corners pressed at the corners of the κ = 0.5 box, a corner lifting beyond it and at the 1 cm margin's
box), the setting's error. ``BalanceConfig.cop_margin`` 2.5 cm instead of 1 cm (the rule's candidate; it failed, the
standing mode keeps 1 cm): a standing handshake whose planted feet slide less with it (docs/design.md §5, "The
standing mode's feet tipping onto their edges …")."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.support_box import cop_interval, cop_intervals

SOLE = np.array([[x, y] for x in (-0.11, 0.11) for y in (-0.055, 0.055)]) + np.array([0.3, -0.1])
"""Stubby's sole (its foot box's 0.22 × 0.11 m bottom face, ``assets/robots/ours.xml``), somewhere on the floor."""
AXES = np.eye(2)


def test_the_kern_keeps_the_middle_fraction_of_each_half_extent() -> None:
    mid = SOLE.mean(axis=0)
    plain = cop_interval(AXES, SOLE, SOLE, 0.01)
    np.testing.assert_allclose(plain, [[0.3 - 0.10, 0.3 + 0.10], [-0.1 - 0.045, -0.1 + 0.045]], atol=1e-12)
    np.testing.assert_array_equal(cop_interval(AXES, SOLE, SOLE, 0.01, None), plain)  # None: the margin only
    half = cop_interval(AXES, SOLE, SOLE, 0.01, 0.5)
    np.testing.assert_allclose(half, [[mid[0] - 0.055, mid[0] + 0.055], [mid[1] - 0.0275, mid[1] + 0.0275]], atol=1e-12)
    # the margin still binds where it is the tighter of the two (κ = 1: the whole sole, the margin's box)
    np.testing.assert_allclose(cop_interval(AXES, SOLE, SOLE, 0.01, 1.0), plain, atol=1e-12)
    wide = cop_interval(AXES, SOLE, SOLE, 0.04, 0.9)  # x: 0.9 · 0.11 = 0.099 > 0.07; y: 0.9 · 0.055 = 0.0495 > 0.015
    np.testing.assert_allclose(wide, [[0.3 - 0.07, 0.3 + 0.07], [-0.1 - 0.015, -0.1 + 0.015]], atol=1e-12)
    # within the contact points' extent, as without it (touching at the +y corners only: their edge)
    pts = SOLE[[1, 3]]
    np.testing.assert_allclose(cop_interval(AXES, SOLE, pts, 0.01, 0.5)[1], [-0.045, -0.045], atol=1e-12)
    both = cop_intervals(AXES, [SOLE, SOLE + 0.2], [SOLE, SOLE + 0.2], 0.01, 0.5)
    np.testing.assert_allclose(both[1], half + 0.2, atol=1e-12)
    # a pair: κ_forward along the first axis, κ_left along the second (here the forward one the margin's)
    pair = cop_interval(AXES, SOLE, SOLE, 0.01, (1.0, 0.5))
    np.testing.assert_allclose(pair, [plain[0], half[1]], atol=1e-12)
    turned = np.array([[0.0, 1.0], [-1.0, 0.0]])  # the heading along +y: κ_left now across the sole's length
    np.testing.assert_allclose(cop_interval(turned, SOLE, SOLE, 0.01, (1.0, 0.5))[1],
                               sorted([-(mid[0] - 0.055), -(mid[0] + 0.055)]), atol=1e-12)


def _corner_loads(e: np.ndarray) -> np.ndarray:
    """(4,) the loads of a rigid sole's four corners (``SOLE`` about its middle) on four equal springs carrying a unit
    weight at the centre of pressure ``e`` (2,) (from the middle): the plate's sink w and tilts (α, β), each corner
    pressed k (w + α x + β y), from the three equilibrium equations (force, and its moment about either axis)."""
    c = SOLE - SOLE.mean(axis=0)
    rows = np.column_stack([np.ones(4), c[:, 0], c[:, 1]])  # a corner's spring compression per (w, α, β)
    eq = np.array([rows.sum(axis=0), (rows * c[:, :1]).sum(axis=0), (rows * c[:, 1:]).sum(axis=0)])
    w = np.linalg.solve(eq, np.array([1.0, e[0], e[1]]))
    return rows @ w


def test_at_half_the_extents_all_four_corners_stay_pressed_and_beyond_one_lifts() -> None:
    mid = SOLE.mean(axis=0)
    for kappa, margin, pressed in ((0.5, 0.01, True), (0.6, 0.01, False), (None, 0.01, False), (None, 0.03, False)):
        iv = cop_interval(AXES, SOLE, SOLE, margin, kappa)
        worst = min(_corner_loads(np.array([x, y]) - mid).min() for x in iv[0] for y in iv[1])
        if pressed:
            assert worst >= -1e-12, (kappa, margin, worst)  # the far corner just pressed (0 at the box's corners)
        else:
            assert worst < -0.01, (kappa, margin, worst)  # a corner would have to pull: it lifts, the sole tips
    # and everywhere inside the κ = 0.5 box
    iv = cop_interval(AXES, SOLE, SOLE, 0.01, 0.5)
    grid = np.stack(np.meshgrid(np.linspace(*iv[0], 7), np.linspace(*iv[1], 7)), axis=-1).reshape(-1, 2)
    assert min(_corner_loads(p - mid).min() for p in grid) >= -1e-12


@pytest.mark.parametrize("bad", [0.0, -0.2, 1.5, (1.0, 0.0), (0.5, 1.2), (0.5, 0.5, 0.5)])
def test_a_kern_outside_zero_to_one_is_a_one_line_error(bad) -> None:
    with pytest.raises(ConfigError, match="BalanceConfig.cop_kern"):
        BalanceConfig(cop_kern=bad)


def test_off_by_default() -> None:
    assert BalanceConfig().cop_kern is None


def test_standing_handshake_slides_less_with_the_centre_of_pressure_farther_from_the_edges() -> None:
    """shake_hands_128 (a spent instance), ground truth, the standing mode: the contact phase's slide path (the support
    meter's) with each foot's centre of pressure 2.5 cm inside its sole against 1 cm (6.6 → 3.3 cm in development);
    the handshake is met either way."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=129)).of_label(
        "shake_hands"))[128]
    out = {}
    for margin in (0.01, 0.025):
        base = SimConfig.standing()
        cfg = SimConfig.standing(balance=dataclasses.replace(base.balance, cop_margin=margin))
        out[margin] = run_episode(Simulator(load_robot("ours"), "shake_hands", cfg), GroundTruthSource(), inter)
    before = out[0.01]["support"]["contact_phase"]["foot_slide_cm"]
    after = out[0.025]["support"]["contact_phase"]["foot_slide_cm"]
    assert out[0.01]["success"] and out[0.025]["success"]
    assert after < before - 1.5, (before, after)
