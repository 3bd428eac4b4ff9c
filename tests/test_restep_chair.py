"""``FootLockConfig.restep_chair`` = d_c: in a task whose person sits (the pull-up), on a robot whose feet's roll the
balance controller does not free (Stubby), a walk-up's foot standing farther than d_c from where it is planted steps
again (``restep_gap`` = d_c, whatever its own gates say); elsewhere the option is dropped. The gate's cases in
:meth:`FootLockConfig.for_episode`, the check, the distance's boundary through the gated config against a distance
built independently, and Stubby's spent pull_up_812 (changed, more glide steps) and a hand over (bit for bit)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, frame_states, planted_lock, standing_with, synthetic_instance

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.simulator import SimConfig

D_C = 0.15  # not #64's 0.25, so that a re-step gap of d_c can only come from this gate


def _lock(d_c: float | None = D_C) -> FootLockConfig:
    return standing_with("foot_lock", restep_chair=d_c).foot_lock


@pytest.mark.parametrize(("chair", "roll_freed", "plan_feet", "counts_above", "gap"), [
    (True, False, True, False, D_C),  # Stubby's pull-up: d_c
    (False, False, True, False, None),  # Stubby, no chair: #64's gates drop restep_gap (not the H1)
    (True, True, True, False, None),  # the H1's pull-up: not this gate's; #64's drop it (not a high five)
    (True, False, False, False, None),  # the source's feet are not planned: no re-step at all
    (False, True, True, True, 0.25),  # the H1's high five: #64's own re-step, unchanged
    (False, False, True, True, None),  # Stubby's high five: #64's robot gate drops it
])
def test_the_gate_sets_the_restep_gap_only_in_stubbys_pull_up(chair: bool, roll_freed: bool, plan_feet: bool,
                                                               counts_above: bool, gap: float | None) -> None:
    out = _lock().for_episode(plan_feet=plan_feet, causal=False, counts_above=counts_above, roll_freed=roll_freed,
                              chair=chair)
    assert out.restep_gap == gap
    assert out.restep_chair is None  # the episode's config carries the outcome only
    if gap == D_C:  # restep_gap's own gates cleared, or they would drop it again downstream
        assert not out.restep_above and not out.restep_roll_free
    # Without the option the chair changes nothing.
    kw = dict(plan_feet=plan_feet, causal=False, counts_above=counts_above, roll_freed=roll_freed)
    assert _lock(None).for_episode(**kw, chair=chair) == _lock(None).for_episode(**kw, chair=not chair)


def test_the_check_and_off_by_default() -> None:
    for bad in (0.0, -0.1):
        with pytest.raises(ConfigError, match="restep_chair"):
            FootLockConfig(glide_step=0.05, restep_chair=bad)
    assert FootLockConfig().restep_chair is None
    assert SimConfig.standing().foot_lock.restep_chair is None
    assert SimConfig().foot_lock is None or SimConfig().foot_lock.restep_chair is None


@pytest.mark.parametrize(("extra", "steps"), [(+0.001, 1), (-0.001, 0)])
def test_the_pull_ups_gap_is_d_c_through_the_gate(extra: float, steps: int) -> None:
    """The per-episode config of Stubby's pull-up in a foot lock: the right foot's physical ankle placed obliquely
    (35° from the x axis) at d_c ± 1 mm from its planted point, the distance built from its polar form rather than
    read back with a norm: beyond d_c it steps again, within it stays."""
    cfg = _lock().for_episode(plan_feet=True, causal=False, counts_above=False, roll_freed=False, chair=True)
    r, a = D_C + extra, math.radians(35.0)
    physical = ANKLES + np.array([[0.0, 0.0, 0.0], [-r * math.cos(a), -r * math.sin(a), 0.0]])
    lock = planted_lock(cfg)
    lock.apply(ANKLES, physical=physical)
    assert lock.glide_steps == steps
    assert lock.standing == ((True, False) if steps else (True, True))
    # The same foot in a hand over's config (no chair) never steps again, however far behind.
    other = _lock().for_episode(plan_feet=True, causal=False, counts_above=False, roll_freed=False, chair=False)
    lock = planted_lock(other)
    lock.apply(ANKLES, physical=physical)
    assert lock.glide_steps == 0


def _with(d_c: float | None = None, gap: float | None = None) -> SimConfig:
    if gap is not None:  # restep_gap without any gate: what the option does, in every task
        return standing_with("foot_lock", restep_gap=gap, restep_above=False, restep_roll_free=False, restep_chair=d_c)
    return standing_with("foot_lock", restep_chair=d_c)


def test_stubbys_pull_up_changes_and_a_hand_over_is_bit_for_bit() -> None:
    """Spent pull_up_812 (its walk-up's left sole dragged onto its toe, docs/design.md §5, session 37): its states
    differ with d_c = 0.25 m; spent hand_over_812 under the option (d_c = 0.08 m, where its walk-up's feet would
    step again) equals the standing mode bit for bit, and with that re-step ungated (``restep_gap`` = 0.08 without its
    gates) it differs, so the check can fail."""
    pu = synthetic_instance("pull_up", 812)
    a, b = frame_states(_with(), pu), frame_states(_with(0.25), pu)
    assert any(not np.array_equal(x, y) for x, y in zip(a, b))
    ho = synthetic_instance("hand_over", 812)
    a, b = frame_states(_with(), ho), frame_states(_with(0.08), ho)
    assert len(a) == len(b) > 10
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    u = frame_states(_with(gap=0.08), ho)
    assert any(not np.array_equal(x, y) for x, y in zip(a, u))
