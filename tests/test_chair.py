"""The chair of the pull-up scene: declared by the task file, placed under the seated person's thighs."""

from __future__ import annotations

import textwrap
from pathlib import Path

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.chair import SEAT_HALF
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import available_tasks, load_task

TASK = """
interaction = "sit_and_rise"
chair = {value}
[[subgoal]]
name = "touch"
kind = "contact"
robot = "hands"
human = "hands"
"""


def test_only_the_pull_up_has_a_chair() -> None:
    assert {t: load_task(t).chair for t in available_tasks()} == {t: t == "pull_up" for t in available_tasks()}


def test_chair_key_must_be_a_boolean(tmp_path: Path) -> None:
    path = tmp_path / "task.toml"
    path.write_text(textwrap.dedent(TASK.format(value='"yes"')))
    with pytest.raises(ConfigError, match=r"'chair'.*expected true or false") as info:
        load_task(path)
    assert str(path) in str(info.value)
    path.write_text(textwrap.dedent(TASK.format(value="true")))
    assert load_task(path).chair is True


def _thigh_bottom(sim: Simulator) -> tuple[float, np.ndarray]:
    """Lowest point (m) of the person's thigh capsules in the scene, and the hips' middle (2,), from the geoms."""
    sc, m, d = sim.scene, sim.scene.model, sim.data
    names = sc.body.layout.joint_names
    thighs = [i for i, (_, c) in enumerate(sc.body.bones) if "knee" in names[c]]
    lows = []
    for i in thighs:
        g = int(sc.human_geom_ids[i])
        axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
        half, r = m.geom_size[g, 1], m.geom_size[g, 0]
        lows.append(min(d.geom_xpos[g][2] + half * axis[2], d.geom_xpos[g][2] - half * axis[2]) - r)
    hips = sim.pose.joints[0][[p for p, _ in sc.body.bones[thighs]]][:, :2].mean(axis=0)
    return float(min(lows)), hips


def test_the_person_sits_on_the_chair_at_the_first_frame() -> None:
    inter = generate_dataset(seed=0).of_label("pull_up").interactions[0]
    sim = Simulator("ours", "pull_up", SimConfig.harness())
    sim.reset(inter)
    m, d = sim.scene.model, sim.data
    mujoco.mj_forward(m, d)
    seat = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "chair_seat")
    assert seat >= 0
    top = d.geom_xpos[seat][2] + m.geom_size[seat, 2]
    bottom, hips = _thigh_bottom(sim)
    # The seat's top at the thighs' underside (the capsules are a little shorter than the bones whose ends
    # place the chair, so they rest at most a few millimetres above it).
    assert 0.0 <= bottom - top <= 0.005
    # The hips are over the seat, not beside it.
    local = d.geom_xmat[seat].reshape(3, 3).T @ (np.append(hips, top) - d.geom_xpos[seat])
    assert np.all(np.abs(local[:2]) <= SEAT_HALF)
    # No contacts: the chair is seen, not touched.
    chair_geoms = [g for g in range(m.ngeom) if (m.geom(g).name or "").startswith("chair_")]
    assert len(chair_geoms) == 6 and not (m.geom_contype[chair_geoms].any() or m.geom_conaffinity[chair_geoms].any())
    # A task without a chair has none in its scene.
    other = Simulator("ours", "shake_hands", SimConfig.harness())
    other.reset(generate_dataset(seed=0).of_label("shake_hands").interactions[0])
    assert mujoco.mj_name2id(other.scene.model, mujoco.mjtObj.mjOBJ_GEOM, "chair_seat") < 0
