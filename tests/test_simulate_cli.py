"""``socialaff-sim simulate`` end to end: metrics.json, video, and the model source's clear error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from socialaff_sim.cli.main import main


@pytest.fixture(scope="module")
def data_dir(shake1_npz: Path) -> Path:
    return shake1_npz


def test_gt_replay_writes_metrics(data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    rc = main(["simulate", "--data", f"npz:{data_dir}", "--instance", "shake_hands_000", "--robot", "ours",
               "--source", "gt", "--out", str(out), "--no-video"])
    assert rc == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["source"] == "gt" and metrics["robot"] == "ours" and metrics["task"] == "shake_hands"
    assert [s["name"] for s in metrics["subgoals"]] == ["hands_clasped"]
    for key in ("ik_error_m", "ik_ms_per_frame", "contact_force_on_human_n", "wall_seconds", "real_time_factor",
                "failures", "success", "simulated_seconds"):
        assert key in metrics
    assert set(metrics["ik_error_m"]) == {"base", "left_wrist", "right_wrist", "left_ankle", "right_ankle"}
    assert len(metrics["contact_force_on_human_n"]["per_frame"]) == metrics["frames"] - 1
    assert metrics["simulated_seconds"] == pytest.approx((metrics["frames"] - 1) / metrics["fps"], rel=1e-9)
    assert metrics["video"].startswith("disabled")
    printed = capsys.readouterr().out
    assert "hands_clasped" in printed and "real-time factor" in printed


def test_a_broken_model_file_is_named(data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "model.npz"
    model.write_bytes(b"")  # truncated: not an .npz
    rc = main(["simulate", "--model", str(model), "--data", f"npz:{data_dir}", "--instance", "shake_hands_000",
               "--out", str(tmp_path / "run"), "--no-video"])
    assert rc == 2
    err = capsys.readouterr().err
    assert str(model) in err and "not a readable model file" in err
    assert not (tmp_path / "run" / "metrics.json").exists()
    rc = main(["simulate", "--model", str(tmp_path / "absent.npz"), "--data", f"npz:{data_dir}", "--instance",
               "shake_hands_000", "--out", str(tmp_path / "run"), "--no-video"])
    assert rc == 2 and "absent.npz: no such model file" in capsys.readouterr().err


def test_bad_arguments_are_reported(data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["simulate", "--data", f"npz:{data_dir}", "--instance", "nope", "--source", "gt",
               "--out", str(tmp_path), "--no-video"])
    assert rc == 2 and "no instance 'nope'" in capsys.readouterr().err
    rc = main(["simulate", "--data", f"npz:{data_dir}", "--instance", "0", "--source", "gt", "--robot", "r2d2",
               "--out", str(tmp_path), "--no-video"])
    assert rc == 2 and "shipped robots: 'cmu', 'ours', 'unitree_g1' or 'unitree_h1'" in capsys.readouterr().err
    rc = main(["simulate", "--data", f"npz:{data_dir}", "--instance", "0", "--out", str(tmp_path), "--no-video"])
    assert rc == 2 and "--source model needs --model" in capsys.readouterr().err


@pytest.mark.render
def test_video_is_written(data_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    rc = main(["simulate", "--data", f"npz:{data_dir}", "--instance", "0", "--robot", "ours", "--source", "gt",
               "--out", str(out), "--width", "160", "--height", "128"])
    assert rc == 0
    metrics = json.loads((out / "metrics.json").read_text())
    if metrics["video"].startswith("not written"):
        pytest.skip(metrics["video"])
    assert (out / "video.mp4").stat().st_size > 1000 and (out / "contact_sheet.png").exists()


def test_a_robot_without_its_model_is_reported_before_any_data_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The data folder does not exist either: reading the data first would report that instead.
    rc = main(["simulate", "--robot", "unitree_h1", "--source", "gt", "--data", f"npz:{tmp_path / 'nowhere'}",
               "--instance", "x", "--out", str(tmp_path / "out"), "--no-video"])
    err = capsys.readouterr().err
    assert rc == 2 and "needs its MJCF model" in err and "--mjcf PATH" in err and "nowhere" not in err
