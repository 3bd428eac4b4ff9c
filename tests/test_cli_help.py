"""Every sub-command says what it does and shows an example; errors and endings say what to do next."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import pytest

from socialaff_sim.cli.main import build_parser, main
from socialaff_sim.cli.progress import FrameProgress, Reporter
from socialaff_sim.data import save_dataset
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.learning import SocialAffordanceModel


def _commands(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):  # noqa: ANN202
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield (*prefix, name), child
                yield from _commands(child, (*prefix, name))


def test_every_command_has_a_description_and_an_example() -> None:
    commands = list(_commands(build_parser()))
    assert {c[0][0] for c in commands} >= {"data", "fit", "show", "synthesize", "evaluate", "simulate", "demo"}
    for path, parser in commands:
        text = parser.format_help()
        assert parser.description and len(parser.description) > 40, path
        assert f"socialaff-sim {' '.join(path)}" in (parser.epilog or ""), f"{path}: no example in the epilog"
        assert "--quiet" in text and "--verbose" in text, path
        # examples are printed whole, one per line
        for line in (parser.epilog or "").splitlines():
            if line.startswith("  socialaff-sim"):
                assert line in text, (path, line)


def test_verbose_logs_the_rendering_choice(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    assert main(["data", "synth", "--quiet"]) == 0
    assert "rendering:" not in caplog.text
    assert main(["data", "synth", "--verbose"]) == 0
    assert "rendering: MUJOCO_GL=" in caplog.text
    assert logging.getLogger("socialaff_sim").level == logging.NOTSET  # restored after the command


def test_synthesize_names_the_mismatch_and_the_fix(
    shake8_model: SocialAffordanceModel, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = shake8_model.save(tmp_path / "m.npz")
    data = generate_dataset(0, SyntheticConfig(interactions=("shake_hands", "high_five"), instances_per_interaction=3))
    save_dataset(data, tmp_path / "data")
    other = next(i for i in data if i.label == "high_five")
    code = main(["synthesize", "--model", str(model), "--data", f"npz:{tmp_path / 'data'}",
                 "--instance", other.instance_id, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{other.instance_id!r} is a 'high_five' interaction" in err and "models 'shake_hands'" in err
    assert "--interaction high_five" in err
    assert not (tmp_path / "out").exists()


class _Sim:
    n_frames = 8

    def __init__(self) -> None:
        self.frame = 0


def test_frame_progress_reports_each_quarter_once_and_calls_the_recorder() -> None:
    said: list[str] = []
    seen: list[int] = []
    progress = FrameProgress(said.append, "x", lambda sim, result, sub: seen.append(sim.frame))
    sim = _Sim()
    progress(sim, None, None)
    for f in range(1, 8):
        sim.frame = f
        progress(sim, object(), "approach")
    assert seen == list(range(8))
    assert said == ["x: 8 frames to simulate", "x: frame 2/8 (sub-event approach)", "x: frame 4/8 (sub-event approach)",
                    "x: frame 6/8 (sub-event approach)", "x: frame 8/8 (sub-event approach)"]


def test_simulate_reports_the_episode_unless_quiet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = generate_dataset(0, SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=1))
    save_dataset(data, tmp_path / "data")
    args = ["simulate", "--data", f"npz:{tmp_path / 'data'}", "--instance", "0", "--source", "gt", "--no-video"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    loud = capsys.readouterr().err
    n = data[0].n_frames
    assert "frames to simulate" in loud and f"frame {n}/{n}" in loud
    assert main([*args, "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_reporter_is_silent_when_quiet(capsys: pytest.CaptureFixture[str]) -> None:
    Reporter(quiet=True)("hidden")
    Reporter(quiet=False)("shown")
    err = capsys.readouterr().err
    assert "hidden" not in err and "shown" in err
