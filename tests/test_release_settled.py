"""The harness's release of a settled swing on a robot whose feet's roll is freed
(BalanceConfig(release_settled_tilt=θ_s, release_settled_rate=ω_s)): the decision (beyond ``release_tilt`` let go up
to θ_s, boundary included, only while the torso's horizontal angular speed is at most ω_s, boundary included; on
another robot or without the option ``release_tilt``; the delay, the capture point and ``catch_tilt`` unchanged), the
settings' check, the gate (Stubby's controller gets no bound and its standing pull-up runs bit for bit as without the
option; the H1's gets it and its pull-up changes) and the controller passing the torso's swing speed (against
MuJoCo's mj_objectVelocity)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_control import BalanceConfig
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

from conftest import shared_robot

BASE = STANDING_BALANCE  # (flat_roll_free, which the option needs)
ON = dataclasses.replace(BASE, release_settled_tilt=8.0, release_settled_rate=10.0)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
MIDDLE = np.zeros(2)


def _released(scene, config: BalanceConfig, roll_freed: bool, tilt: float, rate: float,  # noqa: ANN001
              planted: float = 0.2, capture: np.ndarray = MIDDLE) -> bool:
    h = HarnessRelease(scene, config, roll_freed)
    d = mujoco.MjData(scene.model)
    h.decide(d, planted, True, tilt, BOX, capture, False, rate)  # planted for `planted` s
    return h.released


def test_a_settled_swing_is_let_go_up_to_the_settled_tilt(scene) -> None:  # noqa: ANN001
    for tilt, rate, roll_freed, expected in (
            (4.9, 50.0, True, True),  # within release_tilt: let go however fast it swings
            (6.0, 5.0, True, True),  # beyond release_tilt, settled: let go
            (8.0, 10.0, True, True),  # both bounds included
            (8.1, 5.0, True, False),  # beyond θ_s
            (6.0, 10.1, True, False),  # still swinging
            (6.0, 5.0, False, False)):  # a robot whose feet's roll is not freed: release_tilt
        assert _released(scene, ON, roll_freed, tilt, rate) == expected, (tilt, rate, roll_freed)
    assert not _released(scene, BASE, True, 6.0, 0.0)  # off
    assert not _released(scene, ON, True, 6.0, 0.0, planted=0.05)  # the delay as ever
    assert not _released(scene, ON, True, 6.0, 0.0, capture=np.array([0.095, 0.0]))  # the capture margin as ever
    assert HarnessRelease(scene, ON, True).settled_tilt == 8.0
    assert HarnessRelease(scene, ON, False).settled_tilt is None and HarnessRelease(scene, BASE, True).settled_tilt is None


def test_the_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 7.5, BOX, MIDDLE, False, 0.0)
    assert h.released
    h.decide(d, 0.002, True, 11.9, BOX, MIDDLE, False, 90.0)  # within catch_tilt (12°), swinging: stays released
    assert h.released and h.catches == 0
    h.decide(d, 0.002, True, 12.1, BOX, MIDDLE, False, 0.0)
    assert not h.released and h.catch_reasons["tilt"] == 1


@pytest.mark.parametrize("kw", [{"release_settled_tilt": 8.0, "flat_roll_free": False, "hand_task_roll_free": False},
                                {"release_settled_tilt": 4.0}, {"release_settled_tilt": 12.0},
                                {"release_settled_tilt": 8.0, "release_settled_rate": 0.0},
                                {"release_settled_tilt": 8.0, "release_tilt_touched": 8.0}])
def test_release_settled_tilt_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="release_settled_tilt"):
        dataclasses.replace(BASE, **kw)
    assert dataclasses.replace(BASE, release_settled_tilt=5.0).release_settled_tilt == 5.0  # release_tilt is allowed


def _pull(robot, instance: str, **balance):  # noqa: ANN001, ANN003, ANN202
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    n = int(instance.rsplit("_", 1)[1]) + 1
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=n)).by_id(instance)
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, **balance))
    sim = Simulator(robot, instance.rsplit("_", 1)[0], cfg)
    rates: list[tuple[float, float]] = []  # (passed, mj_objectVelocity's)

    def hook(s, r, sub) -> None:  # noqa: ANN001
        bal = s._stage.stepper.balance
        h, m = bal.harness, s._stage.scene.model
        if getattr(h, "_probe", False):
            return
        orig = h.decide
        v6 = np.zeros(6)

        def decide(*a, **k):  # noqa: ANN002, ANN003, ANN202
            mujoco.mj_objectVelocity(m, a[0], mujoco.mjtObj.mjOBJ_BODY, bal._torso, v6, 0)  # (world axes)
            rates.append((float(a[7]) if len(a) > 7 else float(k.get("rate", 0.0)),
                          math.degrees(math.hypot(v6[0], v6[1]))))
            return orig(*a, **k)
        h.decide, h._probe = decide, True
    m_ = run_episode(sim, GroundTruthSource(), inter, on_frame=hook)
    return sim._stage.stepper.balance, m_, rates


KEYS = ("support", "subgoals", "success", "failures")


def test_stubby_runs_bit_for_bit_as_without_the_option() -> None:
    """Stubby's feet's roll is not freed: its controller gets no bound, passes no speed, and its standing pull-up
    (spent instance pull_up_120) is the same, figure for figure."""
    bal, m_off, _ = _pull("ours", "pull_up_120")
    bal_on, m_on, rates = _pull("ours", "pull_up_120", release_settled_tilt=8.0)
    assert bal.roll_freed is False and bal_on.harness.settled_tilt is None
    assert rates and all(p == 0.0 for p, _ in rates)
    assert all(m_on[k] == m_off[k] for k in KEYS)


def test_the_h1_gets_the_bound_its_swing_speed_and_its_pull_up_changes() -> None:
    """The H1 (skipped without ../shared/robots): its controller frees the feet's roll, gets θ_s, passes the torso's
    horizontal angular speed (equal to mj_objectVelocity's), and its pull-up on spent pull_up_437 (one of the
    two of 40 development episodes at 432–439 that the option changed) changes (so the Stubby check above can fail)."""
    from socialaff_sim.retarget.robot import load_robot

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal, m_off, rates_off = _pull(spec, "pull_up_437")
    assert bal.harness.settled_tilt is None and all(p == 0.0 for p, _ in rates_off)
    bal_on, m_on, rates = _pull(spec, "pull_up_437", release_settled_tilt=8.0)
    assert bal_on.roll_freed and bal_on.harness.settled_tilt == 8.0
    passed, ref = np.array(rates).T
    assert passed.max() > 1.0 and np.allclose(passed, ref, rtol=1e-9, atol=1e-9)
    assert any(m_on[k] != m_off[k] for k in KEYS)
