"""``ScalingConfig.approach_extension``: the robot moving in toward a contact the model means to make that no
placement brings within ``max_extension`` of the arm (a raised palm above a short robot's shoulders), asked again
with the longer reach e_a. Each decision point inverted fails a test here; the placement it stops at is checked
against the shoulders' distance from the point computed from the scaled base (not from the placement's quadratic)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_contact_approach import _far_pair, _shoulder_gap
from test_retarget import ROBOT, pair

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.scaling import KeyJointScaler, ScalingConfig

# The toy robot's shoulders stand 0.2 m to either side of the base's axis, its arm 0.4 m long: a point over the
# base's line 0.32 m above the shoulders lies sqrt(0.2² + 0.32²) = 0.377 m from either shoulder at the nearest,
# beyond 0.9 of the arm (0.36 m) and within all of it (0.4 m).
HIGH = 0.32


def _high_point(point: np.ndarray) -> np.ndarray:
    return point + (0.0, 0.0, HIGH - 0.1)  # _far_pair's point is 0.1 m above the shoulders


def _run(scaler: KeyJointScaler, point: np.ndarray, keys: np.ndarray, partner: np.ndarray, n: int = 60
         ) -> tuple[bool, np.ndarray]:
    moved = False
    for _ in range(n):
        moved |= scaler.approach(point, np.array([1]), keys, partner)
        out = scaler(keys, partner)
    return moved, out


def _with(scaler: KeyJointScaler, **changes: object) -> KeyJointScaler:
    other = KeyJointScaler(ROBOT, dataclasses.replace(scaler.config, **changes))
    other.reset(pair(distance=3.0), np.zeros(3))
    return other


def test_the_toy_geometry_puts_the_high_point_between_the_two_reaches() -> None:
    assert ROBOT.arm == pytest.approx(0.4)
    np.testing.assert_allclose(np.abs(ROBOT.shoulders[:, 1]), 0.2)
    nearest = float(np.hypot(0.2, HIGH))
    assert 0.9 * ROBOT.arm < nearest < ROBOT.arm


def test_without_the_option_a_point_too_high_for_max_extension_moves_nothing() -> None:
    scaler, keys, partner, point = _far_pair()
    assert scaler.config.approach_extension is None
    moved, _ = _run(scaler, _high_point(point), keys, partner)
    assert not moved and not np.isfinite(scaler.stand_cap)


def test_with_the_option_the_robot_moves_in_until_the_point_is_at_e_a_of_the_arm() -> None:
    base, keys, partner, point = _far_pair()
    scaler = _with(base, approach_extension=1.0)
    start = scaler(keys, partner)
    high = _high_point(point)
    assert _shoulder_gap(scaler, start, high) > ROBOT.arm
    moved, out = _run(scaler, high, keys, partner)
    assert moved and np.isfinite(scaler.stand_cap)
    np.testing.assert_allclose(_shoulder_gap(scaler, out, high), 1.0 * ROBOT.arm, atol=1e-6)
    assert not scaler.approach(high, np.array([1]), keys, partner)  # in reach now: nothing more
    # e_a = 1.05 stops farther out, at 1.05 of the arm.
    farther = _with(base, approach_extension=1.05)
    _, out105 = _run(farther, high, keys, partner)
    np.testing.assert_allclose(_shoulder_gap(farther, out105, high), 1.05 * ROBOT.arm, atol=1e-6)


def test_a_point_max_extension_reaches_is_approached_as_without_the_option() -> None:
    plain, keys, partner, point = _far_pair()
    scaler = _with(plain, approach_extension=1.0)
    m0, out0 = _run(plain, point, keys, partner)
    m1, out1 = _run(scaler, point, keys, partner)
    assert m0 and m1
    np.testing.assert_allclose(out1, out0, atol=1e-12)
    np.testing.assert_allclose(_shoulder_gap(scaler, out1, point), 0.9 * ROBOT.arm, atol=1e-6)


def test_a_point_beyond_e_a_too_moves_nothing() -> None:
    base, keys, partner, point = _far_pair()
    scaler = _with(base, approach_extension=1.0)
    moved, _ = _run(scaler, point + (0.0, 0.0, 2.0), keys, partner)
    assert not moved and not np.isfinite(scaler.stand_cap)


def test_an_extension_below_max_extension_is_refused() -> None:
    with pytest.raises(ConfigError, match="approach_extension"):
        ScalingConfig(approach_extension=0.8)
    assert ScalingConfig(approach_extension=0.9).approach_extension == 0.9
