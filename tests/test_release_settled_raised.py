"""``release_settled`` only in the strike's frames (``BalanceConfig.release_settled_raised``, ``release_settled_latch``,
:meth:`socialaff_sim.sim.harness_release.HarnessRelease.see_plan`): the settings' check, the plan's raised wrist
deciding whether the bound acts (at, above and below h_s; per frame or latched), the release decided with and without
the bound where it would differ, and the controller showing the harness each frame's plan (a walk-up's first frames
are not raised, a high five's strike is)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.arm_contacts import wrist_frames, wrist_positions
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

from conftest import spy_harness_decide

ON = dataclasses.replace(STANDING_BALANCE, release_settled=0.03)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))


def _lift(scene, d: mujoco.MjData) -> np.ndarray:  # noqa: ANN001
    """(2,) each wrist's height above its shoulder, computed here from the scene's frames (independent of the
    harness's own arithmetic)."""
    mujoco.mj_kinematics(scene.model, d)
    w = wrist_positions(d, wrist_frames(scene))
    return w[:, 2] - d.xpos[scene.limb_body_ids[:2], 2]


def _plan(scene) -> tuple[mujoco.MjData, np.ndarray]:  # noqa: ANN001
    d = mujoco.MjData(scene.model)
    return d, _lift(scene, d)


def test_the_settings_are_checked_and_off() -> None:
    for kw in ({"release_settled_raised": 0.0, "release_settled": None}, {"release_settled_raised": float("nan")},
               {"release_settled_latch": True}, {"release_settled_until_touch": True, "release_settled": None}):
        with pytest.raises(ConfigError, match="release_settled_(raised|latch|until_touch)"):
            dataclasses.replace(ON, **kw)
    dataclasses.replace(ON, release_settled_raised=-0.2, release_settled_latch=True)
    assert STANDING_BALANCE.release_settled_raised is None and not STANDING_BALANCE.release_settled_latch
    assert not STANDING_BALANCE.release_settled_until_touch


def test_the_strike_is_a_plan_wrist_at_or_above_h_s(scene) -> None:  # noqa: ANN001
    d, lift = _plan(scene)
    top = float(lift.max())
    for h_s, expected in ((top - 0.01, True), (top, True), (top + 0.01, False)):
        h = HarnessRelease(scene, dataclasses.replace(ON, release_settled_raised=h_s))
        assert not h.strike  # reset: no strike before a plan is seen
        h.see_plan(d)
        assert h.strike == expected, (h_s, top)
    h = HarnessRelease(scene, ON)  # without the option: the bound acts in every frame
    assert h.strike
    h.see_plan(d)
    assert h.strike


def test_per_frame_or_latched(scene) -> None:  # noqa: ANN001
    d, lift = _plan(scene)
    top = float(lift.max())
    hs = [HarnessRelease(scene, dataclasses.replace(ON, release_settled_raised=top, release_settled_latch=latch))
          for latch in (False, True)]
    low = dataclasses.replace(ON, release_settled_raised=top + 0.01)
    for h in hs:
        h.see_plan(d)  # raised
        assert h.strike
        h._raised = low.release_settled_raised  # the next plan counts as below h_s
        h.see_plan(d)
    assert not hs[0].strike and hs[1].strike  # per frame: off again; latched: kept
    hs[1].reset()
    assert not hs[1].strike


def _released(scene, strike_plan: bool | None, capture=(-0.05, 0.0)) -> bool:  # noqa: ANN001
    """The release's decision with the bound in a raised plan's frame (``True``), a walk-up's (``False``), or
    without ``release_settled_raised`` (``None``)."""
    d, lift = _plan(scene)
    config = ON if strike_plan is None else dataclasses.replace(
        ON, release_settled_raised=float(lift.max()) + (0.0 if strike_plan else 0.01))
    h = HarnessRelease(scene, config)
    h.see_plan(d)
    h.decide(d, 0.2, True, 0.0, BOX, np.asarray(capture, float), False, np.zeros(2))
    return h.released


def test_the_bound_acts_only_in_the_strike(scene) -> None:  # noqa: ANN001
    # the capture point 5 cm from the centre of mass, inside the box: held by the bound, let go without it
    assert not _released(scene, True)  # a raised plan: the bound holds the robot
    assert _released(scene, False)  # the walk-up (no raised wrist): let go as without the bound
    assert not _released(scene, None)  # without the option: held in every frame
    assert _released(scene, True, capture=(0.02, 0.0))  # settled: let go in the strike too


def test_the_controller_shows_each_plan() -> None:
    """A replayed high five (spent high_five_001, no gates): the controller calls see_plan once per data
    frame with the IK's plan, the first frames (the walk-up) are not raised and a later one is (the strike)."""
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    data = generate_dataset(seed=0)
    cfg = SimConfig.standing()
    bal = dataclasses.replace(cfg.balance, release_settled=0.03, release_settled_raised=0.0)
    sim = Simulator(load_robot("ours"), "high_five", dataclasses.replace(cfg, balance=bal))
    seen: list[bool] = []

    def hook(s, r, sub) -> None:  # noqa: ANN001
        h = s._stage.stepper.balance.harness
        if getattr(h, "_probe", False):
            return
        orig = h.see_plan

        def see(plan):  # noqa: ANN001, ANN202
            orig(plan)
            seen.append(h.strike)
        h.see_plan, h._probe = see, True
    run_episode(sim, GroundTruthSource(), next(i for i in data if i.instance_id == "high_five_001"), on_frame=hook)
    assert len(seen) > 10 and not any(seen[:3]) and any(seen)


@pytest.mark.parametrize("until_touch", [False, True])
def test_until_touch_lets_go_at_the_touch(scene, until_touch: bool) -> None:  # noqa: ANN001
    """``release_settled_until_touch``: after a touch the bound no longer holds the robot (the capture point 5 cm off
    the centre of mass, inside the box); before it, it does; without the option the touch changes nothing."""
    config = dataclasses.replace(ON, release_settled_until_touch=until_touch)
    for touched in (False, True):
        h = HarnessRelease(scene, config)
        d = mujoco.MjData(scene.model)
        h.decide(d, 0.2, True, 0.0, BOX, np.array([-0.05, 0.0]), touched, np.zeros(2))
        assert h.released == (until_touch and touched), (until_touch, touched)


def test_the_controller_passes_the_touch_only_with_until_touch() -> None:
    """A replayed high five (spent high_five_001) on Stubby, whose harness has no ``release_tilt_touched``: the
    controller passes the arms' touch to the release's decision with ``release_settled_until_touch`` (some step
    after the strike's touch), and ``False`` at every step without it (as before the option)."""
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_001")
    seen = {}
    for until in (False, True):
        cfg = SimConfig.standing()
        bal = dataclasses.replace(cfg.balance, release_settled=0.03, release_settled_until_touch=until)
        sim = Simulator(load_robot("ours"), "high_five", dataclasses.replace(cfg, balance=bal))
        got: list[bool] = []

        run_episode(sim, GroundTruthSource(), inter, on_frame=spy_harness_decide(lambda a, k: got.append(bool(a[6]))))
        seen[until] = got
    assert seen[False] and not any(seen[False])
    assert any(seen[True]) and not seen[True][0]
