"""The harness's release held until the centre of mass has settled (``BalanceConfig.release_settled``,
:mod:`socialaff_sim.sim.harness_release`): the decision (let go only while the capture point lies within ρ of the
centre of mass, boundary included; off: as before), the catch unchanged, the settings' check, the gates (``release_settled_above``: a task with a
contact counted above the shoulders; ``release_settled_causal_only``: a causal synthesis's episode), the simulator
setting them per episode, and the controller passing the centre of mass (a replayed high five changes with it)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_control import BalanceConfig
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

from conftest import spy_harness_decide

BASE = STANDING_BALANCE
ON = dataclasses.replace(BASE, release_settled=0.03)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))


def _released(scene, config: BalanceConfig, capture, com) -> bool:  # noqa: ANN001
    h = HarnessRelease(scene, config)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.asarray(capture, float), False, np.asarray(com, float))  # planted 0.2 s, upright
    return h.released


def test_the_settings_are_checked_and_off_in_the_standing_mode() -> None:
    for kw in ({"release_settled": 0.0}, {"release_settled": -0.01}, {"release_settled_above": True},
               {"release_settled_causal_only": True}):
        with pytest.raises(ConfigError, match="release_settled"):
            dataclasses.replace(BASE, **kw)
    dataclasses.replace(ON, release_settled_above=True, release_settled_causal_only=True)
    c = BalanceConfig()
    assert c.release_settled is None and not (c.release_settled_above or c.release_settled_causal_only)
    assert BASE.release_settled is None


def test_the_release_waits_for_the_capture_point_near_the_centre_of_mass(scene) -> None:  # noqa: ANN001
    for capture, com, expected in (
            ((0.02, 0.0), (0.0, 0.0), True),  # 2 cm apart: let go
            ((0.0, 0.03), (0.0, 0.0), True),  # the bound included
            ((0.0, 0.0), (0.0, 0.031), False),  # 3.1 cm sideways: held
            ((-0.05, 0.0), (0.0, 0.0), False),  # moving back: held
            ((0.05, 0.0), (-0.01, 0.0), False)):  # moving forward 6 cm: held
        assert _released(scene, ON, capture, com) == expected, (capture, com)
        assert _released(scene, BASE, capture, com)  # off: every one of them let go (the capture point in the box)


def test_the_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.zeros(2), False, np.zeros(2))
    assert h.released
    h.decide(d, 0.002, True, 0.0, BOX, np.array([-0.08, 0.0]), False, np.zeros(2))  # 8 cm apart, inside the box
    assert h.released and h.catches == 0


@pytest.mark.parametrize("above_only", [False, True])
@pytest.mark.parametrize("causal_only", [False, True])
def test_the_gates(scene, above_only: bool, causal_only: bool) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, dataclasses.replace(ON, release_settled_above=above_only,
                                                  release_settled_causal_only=causal_only))
    assert h.settled == 0.03
    for above in (False, True):
        for causal in (False, True):
            h.gate_settled(above, causal)
            kept = (above or not above_only) and (causal or not causal_only)
            assert h.settled == (0.03 if kept else None), (above, causal)
    h = HarnessRelease(scene, BASE)
    h.gate_settled(True, True)
    assert h.settled is None


def _sim(label: str, causal: bool, **balance):  # noqa: ANN003, ANN202
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    data = generate_dataset(seed=0)
    cfg = SimConfig.standing()
    sim = Simulator(load_robot("ours"), label, dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance,
                                                                                                    **balance)))
    sim.reset(next(i for i in data if i.instance_id == f"{label}_001"), placement_frames=5 if causal else None)
    return sim._stage.stepper.balance.harness


def test_the_simulator_gates_each_episode() -> None:
    gated = {"release_settled": 0.03, "release_settled_above": True, "release_settled_causal_only": True}
    assert _sim("high_five", True, **gated).settled == 0.03  # a causal high five keeps it
    assert _sim("high_five", False, **gated).settled is None  # its replay drops it
    assert _sim("shake_hands", True, **gated).settled is None  # no contact above the shoulders: dropped
    assert _sim("shake_hands", False, release_settled=0.03).settled == 0.03  # without the gates: kept


def test_the_controller_passes_the_centre_of_mass_and_a_replayed_high_five_changes() -> None:
    """Spent high_five_144 (ground truth): let go with its capture point 12 cm off the centre of mass at main; with
    ρ = 3 cm (no gate) its episode changes, and every standing decision received the centre of mass."""
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=145)).by_id("high_five_144")
    out, coms = [], []
    for balance in ({}, {"release_settled": 0.03}):
        cfg = SimConfig.standing()
        sim = Simulator("ours", "high_five", dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance,
                                                                                                  **balance)))

        out.append(run_episode(sim, GroundTruthSource(), inter, on_frame=spy_harness_decide(
            lambda a, k: coms.append((bool(a[2]), a[7] if len(a) > 7 else k.get("com"))))))
    assert any(out[0][k] != out[1][k] for k in ("support", "subgoals", "success", "failures"))
    standing = [c for s, c in coms if s]
    assert standing and all(c is not None and np.shape(c) == (2,) for c in standing)
