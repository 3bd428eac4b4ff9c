"""A robot's own physics mode: the mapping's ``physics`` key, and who falls back on it when no mode is given."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from socialaff_sim.cli.validate import PHYSICS_CHOICES, add_physics_option
from socialaff_sim.demo import DemoConfig
from socialaff_sim.errors import ConfigError
from socialaff_sim.resources import asset_path
from socialaff_sim.retarget.robot import PHYSICS_MODES, load_robot
from socialaff_sim.sim.sim_config import PHYSICS_MODES as SIM_MODES
from socialaff_sim.sim.simulator import SimConfig, Simulator


def _mapping(tmp_path: Path, physics: str | None) -> Path:
    text = asset_path("robots/ours.toml").read_text().replace('mjcf = "ours.xml"', f'mjcf = "{asset_path("robots/ours.xml")}"')
    text = "\n".join(line for line in text.splitlines() if not line.startswith("physics ="))
    if physics is not None:
        text = text.replace('name = "ours"', f'name = "ours"\nphysics = "{physics}"')
    path = tmp_path / f"mine_{physics}.toml"
    path.write_text(text)
    return path


def test_the_modes_are_one_tuple_everywhere() -> None:
    assert SIM_MODES is PHYSICS_MODES
    assert PHYSICS_CHOICES == PHYSICS_MODES


@pytest.mark.parametrize(("key", "expected"), [(None, "harness"), ("harness", "harness"), ("standing", "standing")])
def test_the_mapping_names_the_robots_mode(tmp_path: Path, key: str | None, expected: str) -> None:
    assert load_robot(_mapping(tmp_path, key)).physics == expected


@pytest.mark.parametrize("mode", PHYSICS_MODES)
def test_a_simulator_without_a_config_runs_the_robots_mode(tmp_path: Path, mode: str) -> None:
    robot = load_robot(_mapping(tmp_path, mode))
    assert Simulator(robot, "shake_hands").config == SimConfig.mode(mode)
    other = "harness" if mode == "standing" else "standing"
    # A config given wins over the robot's own.
    assert Simulator(robot, "shake_hands", SimConfig.mode(other)).config == SimConfig.mode(other)


def test_the_two_modes_differ() -> None:
    # Otherwise the checks above could not tell which mode was picked.
    assert SimConfig.mode("harness") != SimConfig.mode("standing")


def test_the_command_line_leaves_the_mode_to_the_robot_unless_given() -> None:
    parser = argparse.ArgumentParser()
    add_physics_option(parser)
    assert parser.parse_args([]).physics is None
    assert parser.parse_args(["--physics", "harness"]).physics == "harness"


def test_the_demo_leaves_the_mode_to_the_robot_unless_given() -> None:
    assert DemoConfig().physics is None
    assert DemoConfig(physics="standing").physics == "standing"
    with pytest.raises(ConfigError, match="physics mode: expected one of harness, standing, found 'floating'"):
        DemoConfig(physics="floating")
