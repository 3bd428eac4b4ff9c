"""Task files: the shipped ones load; malformed ones fail with precise messages."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.tasks import (
    FAILURE_KINDS,
    HUMAN_GROUPS,
    SUBGOAL_KINDS,
    available_tasks,
    load_task,
    task_for_label,
)

REQUIRED = ("shake_hands", "high_five", "pull_up", "throw_catch", "hand_over")

GOOD = """
interaction = "wave_back"
aliases = ["waving"]
[[subgoal]]
name = "touch"
kind = "contact"
robot = "right_hand"
human = "hands"
min_duration = 0.25
[[failure]]
kind = "contact_force"
threshold = 123.0
"""


def write(tmp_path: Path, text: str, name: str = "task.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_every_interaction_has_a_task_file() -> None:
    assert set(REQUIRED) <= set(available_tasks())
    for name in available_tasks():
        task = load_task(name)
        assert task.interaction == name
        assert task.subgoals, name
        for sg in task.subgoals:
            assert sg.kind in SUBGOAL_KINDS
        for f in task.failures:
            assert f.kind in FAILURE_KINDS and f.threshold >= 0


def test_object_tasks_carry_their_objects() -> None:
    ball = load_task("throw_catch")
    assert ball.object is not None and ball.object.spec.shape == "sphere"
    assert [s.kind for s in ball.subgoals] == ["catch"]
    assert "object_dropped" in [f.kind for f in ball.failures]
    cup = load_task("hand_over")
    assert cup.object is not None and cup.object.spec.shape == "cylinder"
    assert [s.kind for s in cup.subgoals] == ["object_in_hand"]
    pull = load_task("pull_up")
    assert pull.subgoals[0].human == "wrists"


def test_labels_of_real_datasets_map_to_tasks() -> None:
    assert task_for_label("shaking_hands").interaction == "shake_hands"
    assert task_for_label("handshake").interaction == "shake_hands"
    assert task_for_label("handover").interaction == "hand_over"
    with pytest.raises(ConfigError, match="known:.*'shake_hands'"):
        task_for_label("juggling")


def test_values_are_read(tmp_path: Path) -> None:
    task = load_task(write(tmp_path, GOOD))
    assert task.aliases == ("waving",)
    sg = task.subgoals[0]
    assert (sg.name, sg.robot, sg.human, sg.min_duration) == ("touch", "right_hand", "hands", 0.25)
    assert task.failures[0].threshold == 123.0
    assert task.object is None
    assert sg.above == "none"  # the default: a contact counts at any height
    high = load_task(write(tmp_path, GOOD.replace('min_duration = 0.25', 'min_duration = 0.25\nabove = "robot_shoulders"'), "high.toml"))
    assert high.subgoals[0].above == "robot_shoulders"
    assert load_task("high_five").subgoals[0].above == "robot_shoulders"
    assert all(sg.above == "none" for name in available_tasks() if name != "high_five" for sg in load_task(name).subgoals)


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ('kind = "contact"', 'kind = "kiss"', r"subgoal\[0\]\.kind'.*'kiss'.*valid choices: 'contact', 'object_in_hand' or 'catch'"),
        ('human = "hands"', 'human = "elbows"', r"subgoal\[0\]\.human'.*'elbows'.*'left_hand'"),
        ('robot = "right_hand"', 'robot = 3', r"subgoal\[0\]\.robot'.*expected a string.*the number 3"),
        ("min_duration = 0.25", "min_duration = -1", r"min_duration'.*expected a number in \[0.0, 60.0\]"),
        ('name = "touch"', 'name = "Touch Me"', r"subgoal\[0\]\.name'.*snake_case"),
        ('kind = "contact_force"', 'kind = "object_dropped"', r"'object_dropped' needs an \[object\] table"),
        ("min_duration = 0.25", 'above = "head"',
         r"subgoal\[0\]\.above'.*'head'.*valid choices: 'none' or 'robot_shoulders'"),
        ("min_duration = 0.25", "above = 1.5", r"subgoal\[0\]\.above'.*expected a string"),
        ("threshold = 123.0", "thresold = 123.0", r"unknown key 'failure\[0\]\.thresold'; valid keys here: 'kind' or 'threshold'"),
    ],
)
def test_errors_name_file_key_and_choices(tmp_path: Path, old: str, new: str, pattern: str) -> None:
    path = write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(ConfigError, match=pattern) as info:
        load_task(path)
    assert str(path) in str(info.value)


def test_missing_and_duplicate_subgoals(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"key 'subgoal': expected at least one \[\[subgoal\]\] table"):
        load_task(write(tmp_path, 'interaction = "x"\n'))
    twice = GOOD + GOOD[GOOD.index("[[subgoal]]"):GOOD.index("[[failure]]")]
    with pytest.raises(ConfigError, match="repeated: 'touch'"):
        load_task(write(tmp_path, twice))


def test_object_table_is_checked(tmp_path: Path) -> None:
    text = GOOD.replace("[[subgoal]]", '[object]\nshape = "cube"\nsize = [0.1]\nmass = 0.2\n\n[[subgoal]]', 1)
    with pytest.raises(ConfigError, match=r"object\.shape'.*'cube'.*'sphere', 'cylinder' or 'box'"):
        load_task(write(tmp_path, text))
    text = text.replace('"cube"', '"cylinder"')
    with pytest.raises(ConfigError, match=r"object\.size'.*a list of 2 finite numbers"):
        load_task(write(tmp_path, text))


def test_not_toml_and_unknown_name(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_task(write(tmp_path, "interaction = [unclosed"))
    with pytest.raises(ConfigError, match="available: .*'shake_hands'"):
        load_task("no_such_task")
    assert set(HUMAN_GROUPS) >= {"hands", "wrists", "body"}


def test_above_applies_to_contact_sub_goals_only(tmp_path: Path) -> None:
    text = """
    interaction = "catch_it"
    [object]
    shape = "sphere"
    size = [0.04]
    mass = 0.1
    [[subgoal]]
    name = "caught"
    kind = "catch"
    above = "robot_shoulders"
    """
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match=r"key 'subgoal\[0\]\.above' only applies to kind 'contact', not 'catch'") as info:
        load_task(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    assert load_task(write(tmp_path, text.replace('    above = "robot_shoulders"\n', ""), "ok.toml")).subgoals[0].above == "none"


@pytest.mark.parametrize("name, above, catch", [
    ("high_five", True, False),  # its palms count only above the robot's shoulders
    ("shake_hands", False, False),
    ("throw_catch", False, True),  # the thrown object's catch
    ("hand_over", False, False),
])
def test_a_task_says_whether_it_counts_above_a_height_and_whether_it_has_a_catch(name: str, above: bool,
                                                                                 catch: bool) -> None:
    task = load_task(name)
    assert task.counts_above is above
    assert task.has_catch is catch
