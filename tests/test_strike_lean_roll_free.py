"""The plan's lean capped apart on a robot whose feet's roll is freed (``StanceConfig.strike_lean_max_roll_free`` θ_r):
the decision (on such a robot with θ_r set the cap is θ_r; on another robot or without θ_r ``strike_lean_max``), the
capped lean against :func:`strike_lean` called with the cap by hand, and the simulator's gate (Stubby's controller
frees no roll: its standing high five leans as without the option, lean for lean; the H1's (skipped without
../shared/robots) is capped at θ_r where without it the plan leans past θ_r)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.ik import RobotIK
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import strike_lean as lean_module
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.strike_lean import PlanLean, strike_lean

from conftest import shared_robot

SHOULDERS = np.array([[0.0, 0.2, 0.4], [0.0, -0.2, 0.4]])
TARGETS = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.8], [0.0, -0.2, 0.0], [0.0, 0.1, -0.9], [0.0, -0.1, -0.9]])
"""A left wrist raised 0.4 m above its shoulder and 0.5 m ahead: k_l = 30 leans 15° before the cap."""


@pytest.mark.parametrize(("roll_freed", "theta_r", "cap"), [
    (True, 4.0, 4.0),  # a roll-freed robot (the H1) with θ_r: θ_r
    (False, 4.0, 10.0),  # a robot whose feet roll (Stubby): strike_lean_max whatever θ_r
    (True, None, 10.0),  # the option off: strike_lean_max
])
def test_the_cap_by_robot(roll_freed: bool, theta_r: float | None, cap: float) -> None:
    c = StanceConfig(strike_lean=30.0, strike_lean_max=10.0, strike_lean_max_roll_free=theta_r)
    lean = PlanLean(c, counts_above=True, roll_freed=roll_freed)
    assert lean.most == cap
    got = lean.frame(TARGETS, SHOULDERS, None, False, 0)
    assert got == strike_lean(TARGETS, SHOULDERS, 30.0, cap, 0.0)
    assert math.degrees(got) == pytest.approx(cap)


def test_the_default_is_off() -> None:
    assert StanceConfig().strike_lean_max_roll_free is None
    assert SimConfig.standing().stance.strike_lean_max_roll_free is None


def _leans(monkeypatch: pytest.MonkeyPatch, robot: object, **stance: object) -> tuple[list[float], list[bool]]:
    """Every lean the IK gets in a standing ground-truth high five (high_five_000) of ``robot``, and the
    ``roll_freed`` each :class:`PlanLean` was built with."""
    leans: list[float] = []
    freed: list[bool] = []
    orig_solve, orig_init = RobotIK.solve, PlanLean.__init__

    def solve(self, *a, **kw):  # noqa: ANN001, ANN002, ANN003
        leans.append(kw.get("lean", 0.0))
        return orig_solve(self, *a, **kw)

    def init(self, config, counts_above, roll_freed=False):  # noqa: ANN001
        freed.append(roll_freed)
        orig_init(self, config, counts_above, roll_freed)

    monkeypatch.setattr(RobotIK, "solve", solve)
    monkeypatch.setattr(lean_module.PlanLean, "__init__", init)
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label("high_five"))[0]
    base = SimConfig.standing()
    cfg = dataclasses.replace(base, stance=dataclasses.replace(base.stance, **stance))
    run_episode(Simulator(robot, "high_five", cfg), GroundTruthSource(), inter)  # type: ignore[arg-type]
    monkeypatch.undo()
    return leans, freed


def test_stubby_leans_as_without_the_option(monkeypatch: pytest.MonkeyPatch) -> None:
    off, freed_off = _leans(monkeypatch, "ours")
    on, freed_on = _leans(monkeypatch, "ours", strike_lean_max_roll_free=0.0)
    assert set(freed_off) == set(freed_on) == {False}
    assert max(off) > 0.0 and on == off


def test_the_h1_is_capped(monkeypatch: pytest.MonkeyPatch) -> None:
    from socialaff_sim.retarget.robot import load_robot

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    off, freed_off = _leans(monkeypatch, spec)
    on, freed_on = _leans(monkeypatch, spec, strike_lean_max_roll_free=4.0)
    assert set(freed_off) == set(freed_on) == {True}
    assert max(off) > math.radians(4.0) + 1e-6  # without the option the H1's plan leans past θ_r ...
    assert 0.0 < max(on) <= math.radians(4.0) + 1e-12  # ... with it, at most θ_r
