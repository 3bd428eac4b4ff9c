"""A closing gap read a frame ahead (FootLockConfig(hold_step_ahead=k) with ``hold_step_gap`` d_s): the decision
(the last frame's gap within d_s as before; else a gap extrapolated k frames ahead from the last two frames' gaps,
g₁ − k·(g₀ − g₁), within d_s, boundary included; unmeasured gaps and a missing earlier frame never count; nothing
without ``hold_step_gap`` or without the option), ``gap_flags`` passing the earlier frame on, the settings' check, the
robot gate (dropped with ``hold_step_gap`` where the feet's roll is not freed: Stubby bit for bit), the task gate
(``hold_step_ahead_above``: only where the contact counts above the shoulders), the simulator
passing the frame before the last's gaps, and the H1's high_five_794 (spent), whose step at the strike it holds."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig

from conftest import assert_gate_keeps_stubby, shared_robot, synthetic_instance

HOME = (0.08, 0.08)


def _lock(d_s: float | None = 0.25, k: float | None = 1.0) -> FootLock:
    return FootLock(HOME, FootLockConfig(hold_step_gap=d_s, hold_step_ahead=k))


@pytest.mark.parametrize(("k", "before", "gaps", "expected"), [
    (1.0, [0.75], [0.5], True),  # 0.5 − 1·0.25 = 0.25 ≤ 0.25: the boundary counts
    (0.875, [0.75], [0.5], False),  # 0.5 − 0.875·0.25 = 0.28125 > 0.25
    (2.0, [0.625], [0.5], True),  # 0.5 − 2·0.125 = 0.25
    (1.0, [0.5], [0.75], False),  # an opening gap: 0.75 + 0.25, farther
    (1.0, [0.5], [0.5], False),  # a still gap: 0.5
    (0.0, [2.0], [0.5], False),  # k = 0: the last gap alone
    (1.0, [None], [0.3], False),  # unmeasured before
    (1.0, [0.75], [None], False),  # unmeasured now
    (1.0, [None, 0.9], [0.8, 0.5], True),  # the second sub-goal: 0.5 − 0.4 = 0.1
    (1.0, [0.9, None], [0.5, 0.8], True),  # the first: 0.1, paired by position
    (1.0, [0.8, 0.9], [0.9, 0.5], True),  # one of two closes
    (1.0, None, [0.5], False),  # no frame before
    (1.0, [1.0], [0.25], True),  # within d_s already
])
def test_stepless_reads_a_closing_gap_k_frames_ahead(k: float, before, gaps, expected: bool) -> None:  # noqa: ANN001
    lock = _lock(k=k)
    assert lock.stepless(gaps, before) is expected
    assert lock.gap_flags(gaps, before)["still"] is expected  # passed on by gap_flags
    if before is not None:
        ahead = [g1 - k * (g0 - g1) for g0, g1 in zip(before, gaps) if g0 is not None and g1 is not None]
        reference = any(g is not None and g <= 0.25 for g in gaps) or any(a <= 0.25 for a in ahead)
        assert reference is expected  # (the cases' hand figures)


def test_without_the_option_or_hold_step_gap_only_the_last_gap_decides() -> None:
    assert not _lock(k=None).stepless([0.5], [0.75])  # off: as hold_step_gap alone
    assert _lock(k=None).stepless([0.25], [0.75])
    assert not _lock(d_s=None, k=1.0).stepless([0.5], [0.75])  # nothing without hold_step_gap
    assert not _lock(d_s=None, k=1.0).stepless([0.0], [0.75])
    assert not _lock().gap_flags([0.5])["still"]  # gap_flags without the frame before: none read ahead
    assert _lock().gap_flags([0.5], [0.75])["still"]


def test_hold_step_ahead_is_checked_and_off_by_default() -> None:
    with pytest.raises(ConfigError, match="hold_step_ahead"):
        FootLockConfig(hold_step_gap=0.3, hold_step_ahead=-0.5)
    assert FootLockConfig().hold_step_ahead is None
    assert SimConfig.standing().foot_lock.hold_step_ahead is None
    assert FootLockConfig(hold_step_ahead=0.0).hold_step_ahead == 0.0


def test_the_gate_drops_it_with_hold_step_gap_where_the_roll_is_not_freed() -> None:
    lock = dataclasses.replace(SimConfig.standing().foot_lock, hold_step_ahead=1.0)
    kw = dict(plan_feet=True, causal=False, counts_above=True)
    assert lock.for_episode(**kw, roll_freed=True).hold_step_ahead == 1.0
    dropped = lock.for_episode(**kw, roll_freed=False)
    assert dropped.hold_step_ahead is None and dropped.hold_step_gap is None


@pytest.mark.parametrize(("above", "counts_above", "kept"), [
    (True, True, True), (True, False, False), (False, False, True), (False, True, True)])
def test_the_task_gate_keeps_it_only_in_a_task_counted_above_with_the_option(above: bool, counts_above: bool,
                                                                             kept: bool) -> None:
    lock = dataclasses.replace(SimConfig.standing().foot_lock, hold_step_ahead=1.0, hold_step_ahead_above=above)
    out = lock.for_episode(plan_feet=True, causal=False, counts_above=counts_above, roll_freed=True)
    assert out.hold_step_ahead == (1.0 if kept else None)
    assert out.hold_step_gap == 0.3  # hold_step_gap itself is not the task gate's


def test_hold_step_ahead_above_needs_the_option() -> None:
    with pytest.raises(ConfigError, match="hold_step_ahead_above"):
        FootLockConfig(hold_step_gap=0.3, hold_step_ahead_above=True)
    assert not FootLockConfig().hold_step_ahead_above


def test_stubby_is_bit_for_bit_with_the_option() -> None:
    """Stubby's standing pull-up (spent pull_up_122): the same states with ``hold_step_ahead=1``; without the robot
    gate (``hold_near_roll_free=False``) they change, and the option itself changes them there (against the same
    ungated settings without it)."""
    from conftest import frame_states

    inter = list(generate_dataset(0, SyntheticConfig(interactions=("pull_up",), instances_per_interaction=123)))[122]
    assert inter.instance_id == "pull_up_122"
    base = SimConfig.standing()
    on = dataclasses.replace(base, foot_lock=dataclasses.replace(base.foot_lock, hold_step_ahead=1.0))
    ungated = dataclasses.replace(on, foot_lock=dataclasses.replace(on.foot_lock, hold_near_roll_free=False))
    assert_gate_keeps_stubby(inter, base, on, ungated)
    without = dataclasses.replace(ungated, foot_lock=dataclasses.replace(ungated.foot_lock, hold_step_ahead=None))
    u, w = frame_states(ungated, inter), frame_states(without, inter)
    assert any(not np.array_equal(x, y) for x, y in zip(u, w))


def _gap_flag_calls(cfg: SimConfig, monkeypatch: pytest.MonkeyPatch):  # noqa: ANN202
    """Each ``gap_flags`` call's gaps, frame-before gaps and frame count on a standing Stubby high five (spent
    high_five_144) run with ``cfg``, and each frame's gaps."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    calls: list[tuple[list | None, list | None, int]] = []
    results: list[dict] = []
    orig = FootLock.gap_flags

    def spy(self, gaps, before=None):  # noqa: ANN001, ANN202
        calls.append((None if gaps is None else list(gaps), None if before is None else list(before), len(results)))
        return orig(self, gaps, before)

    monkeypatch.setattr(FootLock, "gap_flags", spy)
    run_episode(Simulator("ours", "high_five", cfg), GroundTruthSource(), synthetic_instance("high_five", 144),
                on_frame=lambda s, r, e: results.append(dict(r.subgoal_gaps)) if r is not None else None)
    monkeypatch.undo()
    return calls, results


def test_the_simulator_passes_the_frame_before_the_lasts_gaps(monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``hold_step_ahead`` acting (Stubby, ``hold_near_roll_free`` off so that it is kept): each ``gap_flags``
    call gets the last frame's gaps and, from the third frame on, the frame before's gaps of the same sub-goals
    (before it: ``None``). Without the option the frame before is not read: ``None`` in every call."""
    base = SimConfig.standing()
    on = dataclasses.replace(base, foot_lock=dataclasses.replace(base.foot_lock, hold_near_roll_free=False,
                                                                 hold_step_ahead=1.0))
    calls, results = _gap_flag_calls(on, monkeypatch)
    assert len(calls) > 10
    for gaps, before, n in calls:
        if n == 0:
            assert gaps is None and before is None
        elif n == 1:
            assert gaps == list(results[0].values()) and before is None
        else:
            assert gaps == list(results[n - 1].values()) and before == [results[n - 2][k] for k in results[n - 1]]
    assert any(b is not None and any(x is not None for x in b) for _, b, _ in calls)
    off_calls, off_results = _gap_flag_calls(base, monkeypatch)
    assert len(off_calls) > 10
    for gaps, before, n in off_calls:
        assert before is None and gaps == (None if n == 0 else list(off_results[n - 1].values()))


def test_the_h1s_step_at_the_strike_is_held() -> None:
    """The H1 (skipped without ../shared/robots): spent high_five_794, whose gap closes 0.83 → 0.50 → 0.02 m over
    frames 31–33 and whose foot steps in frame 33 (a harness catch into its lone contact frame, 115 % of its weight):
    with k = 1 the foot lock gets ``still`` first in a call where A's does not, and the episode's figures change."""
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = synthetic_instance("high_five", 794)
    assert inter.instance_id == "high_five_794"
    base = SimConfig.standing()
    runs = {}
    for name, k in (("off", None), ("on", 1.0)):
        cfg = dataclasses.replace(base, foot_lock=dataclasses.replace(base.foot_lock, hold_step_ahead=k,
                                                                      hold_step_ahead_above=k is not None))
        seen: list[bool] = []

        def hook(s, r, e, seen=seen) -> None:  # noqa: ANN001
            fl = s._footlock
            if getattr(fl, "_probe", False):
                return
            orig = fl.apply

            def apply(*a, **kw):  # noqa: ANN002, ANN003, ANN202
                seen.append(bool(kw.get("still", False)))
                return orig(*a, **kw)
            fl.apply, fl._probe = apply, True
        sim = Simulator(spec, "high_five", cfg)
        runs[name] = (run_episode(sim, GroundTruthSource(), inter, on_frame=hook), seen)
    (a, sa), (b, sb) = runs["off"], runs["on"]
    i = next(j for j, (x, y) in enumerate(zip(sa, sb)) if x != y)  # the first call that differs: held by k
    assert sb[i] and not sa[i]
    assert any(a[key] != b[key] for key in ("support", "subgoals", "success"))
