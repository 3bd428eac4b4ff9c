"""The replayed person in the physics: no collision with the object the person carries; the compliant or
kinematic person (``SimConfig.compliant_person``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from conftest import load_script, shared_robot

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.environment import physics_config
from socialaff_sim.errors import ConfigError
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import carry
from socialaff_sim.sim.scene import OBJECT_AFFINITY, PERSON_CONTYPE, build_scene
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def hand_over():
    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label("hand_over")[0]


def _person_object(sim: Simulator) -> tuple[int, float]:
    """(person–object contacts at the last physics step, the smallest person–object geom distance in m)."""
    sc, d = sim.scene, sim.data
    person = set(sc.human_geom_ids.tolist())
    n = sum(1 for g in d.contact.geom[: d.ncon] if sc.object_geom in g and (g[0] in person or g[1] in person))
    gap = min(mujoco.mj_geomDistance(sc.model, d, int(g), sc.object_geom, 1.0, None) for g in sc.human_geom_ids)
    return n, float(gap)


def _replay(inter, config: SimConfig | None = None) -> tuple[Simulator, list[tuple[int, float, bool]]]:
    sim = Simulator("ours", inter.label, config)
    src = GroundTruthSource()
    src.reset(inter)
    sim.reset(inter)
    sim.settle(sim.retarget(src.targets(0).keys, frame=0))
    seen = []
    while not sim.done:
        f = src.targets(sim.frame + 1)
        sim.step(sim.retarget(f.keys, frame=sim.frame + 1), subevent=f.subevent)
        seen.append((*_person_object(sim), bool(sim.scorer.tracks.released)))
    return sim, seen


def test_the_carried_object_does_not_collide_with_the_person_until_the_release(hand_over) -> None:
    sim, seen = _replay(hand_over)
    carried = [s for s in seen if not s[2]]
    assert carried and len(carried) < len(seen), "the instance must have a carry and a release"
    # The person's capsule hand overlaps the cup it carries (so contacts would be generated) ...
    assert min(gap for _, gap, _ in carried) < 0.0
    # ... but none is: the carry is the recording, not a contact.
    assert all(n == 0 for n, _, _ in carried)
    m = sim.scene.model
    assert m.geom_conaffinity[sim.scene.object_geom] & PERSON_CONTYPE  # released: collides with the person again
    # A fresh reset carries the cup again: the bit is cleared once more.
    sim.reset(hand_over)
    assert not m.geom_conaffinity[sim.scene.object_geom] & PERSON_CONTYPE
    assert not m.body_conaffinity[sim.scene.object_body] & PERSON_CONTYPE


def test_person_contact_switches_only_the_person_bit() -> None:
    scene = build_scene(load_robot("ours"), LAYOUT, load_task("hand_over").object.spec)
    m, g, b = scene.model, scene.object_geom, scene.object_body
    assert m.geom_conaffinity[g] == OBJECT_AFFINITY and OBJECT_AFFINITY & PERSON_CONTYPE
    carry.person_contact(scene, False)
    assert m.geom_conaffinity[g] == OBJECT_AFFINITY & ~PERSON_CONTYPE == m.body_conaffinity[b]
    robot = np.flatnonzero(scene.robot_geom & (m.geom_contype != 0))
    assert (m.geom_contype[robot] & m.geom_conaffinity[g]).all()  # the robot still touches it
    assert (m.geom_contype[scene.human_geom_ids] & m.geom_conaffinity[g] == 0).all()
    carry.person_contact(scene, True)
    assert m.geom_conaffinity[g] == OBJECT_AFFINITY == m.body_conaffinity[b]
    assert (m.geom_contype[scene.human_geom_ids] & m.geom_conaffinity[g]).all()


@pytest.mark.parametrize("compliant", [True, False])
def test_compliant_person_decides_which_parts_are_simulated(compliant: bool) -> None:
    robot = load_robot("ours")
    scene = build_scene(robot, LAYOUT, None, compliant_person=compliant)
    free = scene.human_free_qadr >= 0
    robot_nv = len(scene.robot_vadr)
    if compliant:
        assert free.sum() > 0 and scene.model.nv == robot_nv + 6 * int(free.sum())
        assert scene.model.neq == 1 + int(free.sum())  # the harness and one weld per compliant part
    else:
        assert not free.any() and scene.model.nv == robot_nv and scene.model.neq == 1
        assert len(scene.human_mocap) == len(scene.human_geom_ids)


def test_a_kinematic_person_is_not_pushed(hand_over) -> None:
    """With ``compliant_person=False`` the person's hands are exactly where the recording puts them."""
    for compliant in (True, False):
        sim, _ = _replay(hand_over, SimConfig(compliant_person=compliant))
        sc, d = sim.scene, sim.data
        body = sc.model.geom_bodyid[sc.human_geom_ids[-2:]]  # the hand spheres
        off = np.linalg.norm(d.xpos[body] - sim.pose.pos[sim.frame, -2:], axis=1).max()
        if compliant:
            assert off > 1e-6  # the welds let the hands lag behind the moving recording
        else:
            assert off < 1e-9


def test_env_sim_config_overrides_the_preset() -> None:
    kinematic = dataclasses.replace(physics_config("fast"), compliant_person=False)
    env = gym.make("socialaff_sim/ShakeHands-v0", max_frames=4, sim_config=kinematic)
    preset = gym.make("socialaff_sim/ShakeHands-v0", max_frames=4)
    env.reset(seed=0)
    preset.reset(seed=0)
    assert not (env.unwrapped.simulator.scene.human_free_qadr >= 0).any()
    assert (preset.unwrapped.simulator.scene.human_free_qadr >= 0).any()
    assert env.unwrapped.simulator.config.timestep == preset.unwrapped.simulator.config.timestep
    with pytest.raises(ConfigError, match="sim_config"):
        gym.make("socialaff_sim/ShakeHands-v0", max_frames=4, sim_config={"compliant_person": False})


def test_h1_gripping_the_cup_the_person_still_holds_stays_stable() -> None:
    """Regression: 33 random ``targets`` actions (recorded from scripts/env_stress.py, seed 0) on
    hand_over_013 with the H1 made MuJoCo diverge at frame 33 ("Nan, Inf or huge value in QACC" at the
    person's right hand tip), when the person's hand parts still collided with the cup they carry and the
    robot's grip held the same cup. Without those contacts the episode runs on."""
    robot = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    actions = np.load(Path(__file__).parent / "data" / "h1_hand_over_013_targets.npy")
    env = gym.make("socialaff_sim/SocialAffordance-v0", robot=robot, action_mode="targets",
                   control_dt=None)  # the stress run's actions were one per data frame
    env.reset(seed=1321529464)
    assert env.unwrapped.simulator.interaction.instance_id == "hand_over_013"
    for a in actions:
        _, _, term, trunc, info = env.step(a)
        assert not any(info["physics_warnings"].values()), info["physics_warnings"]
        assert info["termination_reason"] != "physics_unstable"
        if term or trunc:
            break
    assert env.unwrapped.simulator.frame == len(actions)  # the episode reached the frame that diverged


def test_speed_option_settings_replace_only_what_they_name() -> None:
    fidelity, bench = load_script("bench_env_fidelity"), load_script("bench_env")
    preset = physics_config("fast")
    cfg = fidelity.parse_setting("compliant_person=False; timestep=0.012; ik.iterations=2", "fast")
    assert (cfg.compliant_person, cfg.timestep, cfg.ik.iterations) == (False, 0.012, 2)
    assert dataclasses.replace(cfg, compliant_person=True, timestep=preset.timestep,
                               ik=dataclasses.replace(cfg.ik, iterations=preset.ik.iterations)) == preset
    assert fidelity.parse_setting("", "fast") == preset
    assert bench.sim_options("fast", None, None, None) is None
    assert bench.sim_options("fast", 0, 0.012, 2) == cfg
    assert bench.sim_options("fast", 1, None, None) == preset  # compliant is the preset's own value
