"""One outcome code per episode (sim/outcome.py) and the fall it can report (sim/fall.py)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.sources import GroundTruthSource, SourceFrame
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.fall import FALL_HEIGHT, FALL_TILT, FallWatch
from socialaff_sim.sim.outcome import OUTCOMES, episode_outcome
from socialaff_sim.sim.scoring import FailureResult, SubgoalResult
from socialaff_sim.sim.simulator import Simulator


def goal(success: bool = False, time: float | None = None, first: float | None = None, last: float | None = None,
         current: bool = False, low: bool = False) -> SubgoalResult:
    return SubgoalResult("g", "contact", success=success, time=time, current=current, low=low, first_touch=first,
                         last_touch=last)


def failure(kind: str, time: float | None) -> FailureResult:
    return FailureResult(kind, 1.0, triggered=time is not None, time=time)


def test_every_sub_goal_met_and_nothing_else_is_a_success_at_the_last_sub_goals_time() -> None:
    goals = [goal(True, 1.2, 1.0, 2.0), goal(True, 2.5, 2.0, 2.6)]
    assert episode_outcome(goals, [failure("contact_force", None)], None, 4.0) == ("success", 2.5)


@pytest.mark.parametrize("kind", ["self_collision", "contact_force", "object_dropped"])
def test_a_triggered_failure_is_the_outcome_even_after_every_sub_goal_was_met(kind: str) -> None:
    goals = [goal(True, 1.0, 0.5, 3.0, current=True)]
    assert episode_outcome(goals, [failure(kind, 3.5)], None, 4.0) == (kind, 3.5)


def test_the_earliest_failure_wins_whatever_the_task_files_order() -> None:
    fails = [failure("self_collision", 2.0), failure("contact_force", 1.0), failure("object_dropped", None)]
    assert episode_outcome([goal()], fails, None, 4.0) == ("contact_force", 1.0)
    fails = [failure("self_collision", 0.5), failure("contact_force", 1.0)]
    assert episode_outcome([goal()], fails, None, 4.0) == ("self_collision", 0.5)


def test_a_fall_against_a_failure_is_decided_by_time_and_a_tie_goes_to_the_fall() -> None:
    fails = [failure("contact_force", 2.0)]
    assert episode_outcome([goal(True, 1.0, 0.5, 1.0)], fails, 1.5, 4.0) == ("fell", 1.5)
    assert episode_outcome([goal(True, 1.0, 0.5, 1.0)], fails, 2.5, 4.0) == ("contact_force", 2.0)
    assert episode_outcome([goal()], fails, 2.0, 4.0) == ("fell", 2.0)
    assert episode_outcome([goal(True, 1.0, 0.5, 1.0)], [], 3.0, 4.0) == ("fell", 3.0)  # a fall spoils a success


def test_an_unmet_sub_goal_never_touched_is_no_contact() -> None:
    assert episode_outcome([goal()], [], None, 4.0) == ("no_contact", None)


def test_an_unmet_sub_goal_touched_and_let_go_is_contact_lost_at_its_last_touch() -> None:
    assert episode_outcome([goal(first=1.0, last=1.2)], [], None, 4.0) == ("contact_lost", 1.2)


@pytest.mark.parametrize(("current", "low"), [(True, False), (False, True)])
def test_an_unmet_sub_goal_still_touching_at_the_end_is_a_timeout(current: bool, low: bool) -> None:
    assert episode_outcome([goal(first=3.8, last=4.0, current=current, low=low)], [], None, 4.0) == ("timeout", 4.0)


def test_the_first_unmet_sub_goal_in_the_task_files_order_decides() -> None:
    met, never, lost = goal(True, 1.0, 0.9, 1.1), goal(), goal(first=1.0, last=1.5)
    assert episode_outcome([met, never, lost], [], None, 4.0) == ("no_contact", None)
    assert episode_outcome([met, lost, never], [], None, 4.0) == ("contact_lost", 1.5)


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1))


def _tilted(sim: Simulator, rotvec: np.ndarray, lift: float = 0.0) -> None:
    """Turn the robot's root by ``rotvec`` (rad, world axes) from home and raise it by ``lift`` m (kinematics only)."""
    adr = sim.scene.robot_qadr
    home = np.asarray(sim.scene.home_qpos, dtype=np.float64)
    sim.data.qpos[adr] = home
    w, x, y, z = home[3:7]
    turned = Rotation.from_rotvec(rotvec) * Rotation.from_quat([x, y, z, w])
    qx, qy, qz, qw = turned.as_quat()
    sim.data.qpos[adr[3:7]] = (qw, qx, qy, qz)
    sim.data.qpos[adr[2]] += lift
    mujoco.mj_kinematics(sim.scene.model, sim.data)


def test_a_fall_is_a_trunk_past_the_tilt_or_a_base_below_the_height(data) -> None:
    sim = Simulator("ours", "shake_hands")
    sim.reset(data.of_label("shake_hands")[0])
    watch = FallWatch()
    watch.reset(sim)
    assert (watch.fall_height, watch.fall_tilt) == (FALL_HEIGHT, FALL_TILT)
    base = float(sim.home_key_frames[0, 2])
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0.6, 0.8, 0.0])):
        # Tilts about a horizontal axis through the root, the base raised so it never drops below the height.
        _tilted(sim, np.deg2rad(FALL_TILT - 1.0) * axis, lift=base)
        assert not watch.fallen(sim)
        _tilted(sim, np.deg2rad(FALL_TILT + 1.0) * axis, lift=base)
        assert watch.fallen(sim)
    _tilted(sim, np.array([0.0, 0.0, np.pi / 2]))  # a turn about the vertical is no tilt
    assert not watch.fallen(sim)
    now = float(sim.robot_key_frames()[0, 2])
    _tilted(sim, np.zeros(3), lift=FALL_HEIGHT * base - now + 0.01)
    assert not watch.fallen(sim)
    _tilted(sim, np.zeros(3), lift=FALL_HEIGHT * base - now - 0.01)
    assert watch.fallen(sim)
    assert watch.update(sim, 1.25) and watch.time == 1.25
    _tilted(sim, np.zeros(3))
    assert watch.update(sim, 2.0) and watch.time == 1.25  # the first fall's time is kept
    watch.reset(sim)
    assert watch.time is None and not watch.update(sim, 0.1)


class _Still:
    """Agent 1 held at its first recorded frame: the robot never reaches out."""

    def reset(self, interaction) -> None:
        self._keys = interaction.key_joints()[0, 1].copy()

    def targets(self, t: int) -> SourceFrame:
        return SourceFrame(self._keys.copy(), None)


def test_an_episode_reports_its_outcome_and_success_agrees_with_it(data) -> None:
    inter = data.of_label("shake_hands")[0]
    shake = run_episode(Simulator("ours", "shake_hands"), GroundTruthSource(), inter)
    assert shake["outcome"] == "success" and shake["success"] and shake["fell_at"] is None
    assert shake["outcome_time"] == max(g["time"] for g in shake["subgoals"])
    goal0 = shake["subgoals"][0]
    assert goal0["first_touch"] is not None and goal0["first_touch"] <= goal0["time"] <= goal0["last_touch"]
    still = run_episode(Simulator("ours", "shake_hands"), _Still(), inter)
    assert still["outcome"] == "no_contact" and not still["success"] and still["outcome_time"] is None
    assert still["subgoals"][0]["first_touch"] is None
    assert set(OUTCOMES) >= {shake["outcome"], still["outcome"]}
