"""The demo runs the whole loop and writes a report whose numbers come from the run."""

from __future__ import annotations

from pathlib import Path

import pytest

from socialaff_sim.cli.main import main
from socialaff_sim.demo import DemoConfig, run_demo
from socialaff_sim.errors import ConfigError


def test_demo_one_interaction_writes_a_report(tmp_path: Path) -> None:
    config = DemoConfig(iterations=2, n_test=1, baselines=("promp",), video=False, seed=3)
    (result,) = run_demo(tmp_path, ["hand_over"], config)
    report = (tmp_path / "report.md").read_text()
    assert "| full | " in report and "| promp | " in report
    assert f"{result.errors['full']:.3f}" in report
    for name in (result.groupings_png, result.synthesis_png, "hand_over_model.npz"):
        assert (tmp_path / name).stat().st_size > 0
    assert result.simulation["frames"] > 0 and result.reference["frames"] == result.simulation["frames"]
    assert 0.0 < result.errors["full"] < 2.0 and 0.0 < result.errors["promp"] < 2.0
    assert [s for s, _ in result.subevents] and result.video is None


def test_demo_rejects_unknown_interaction(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="choose from"):
        run_demo(tmp_path, ["hug"], DemoConfig(video=False))
    assert main(["demo", "--interaction", "hug", "--out", str(tmp_path), "--no-video", "--quiet"]) == 2
