"""``socialaff-sim data``: synth, inspect and convert, with a round trip through the npz format."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import shared_path

from socialaff_sim.cli.main import main
from socialaff_sim.data import load_dataset


def test_convert_then_inspect_round_trips_sbu(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = shared_path("sbu_kinect_interaction")
    spec = f"sbu:{root}"
    assert main(["data", "convert", spec, "--out", str(tmp_path)]) == 0
    original = load_dataset(spec)
    back = load_dataset(f"npz:{tmp_path}")
    assert len(back) == len(original) == 225
    by_id = {i.instance_id: i for i in back}
    assert all(i.same_as(by_id[i.instance_id]) for i in original)
    capsys.readouterr()
    assert main(["data", "inspect", f"npz:{tmp_path}"]) == 0
    out = capsys.readouterr().out
    assert "225 instances in 7 classes" in out and "shaking_hands" in out


def test_inspect_prints_classes_and_key_joints(capsys: pytest.CaptureFixture[str]) -> None:
    root = shared_path("handover_h2h")
    assert main(["data", "inspect", f"handover:{root}"]) == 0
    out = capsys.readouterr().out
    assert "150 instances in 1 classes" in out
    assert "hand_over" in out and "0.00|1.00" in out  # the giver's ankles are marked untracked


def test_synth_writes_npz_and_bad_specs_fail_cleanly(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["data", "synth", "--seed", "1", "--out", str(tmp_path)]) == 0
    assert "120 instances in 5 classes" in capsys.readouterr().out
    assert len(list(tmp_path.glob("*.npz"))) == 120
    assert main(["data", "inspect", "kinect:/nowhere"]) == 2
    err = capsys.readouterr().err
    assert "expected one of" in err and "sbu:PATH" in err
