"""`socialaff-sim synthesize`: the written track and plot, in both synthesis modes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.cli.main import main
from socialaff_sim.data import load_interaction
from socialaff_sim.learning import SocialAffordanceModel


@pytest.mark.parametrize("mode", ["offline", "online"])
def test_synthesize_writes_track_and_plot(
    mode: str, shake8, shake8_model: SocialAffordanceModel, tmp_path: Path, capsys: pytest.CaptureFixture[str]  # noqa: ANN001
) -> None:
    model_path = shake8_model.save(tmp_path / "m.npz")
    inter = shake8[7]
    data = tmp_path / "data"
    from socialaff_sim.data import save_dataset

    save_dataset(shake8, data)
    out = tmp_path / f"out_{mode}"
    code = main(["synthesize", "--model", str(model_path), "--data", f"npz:{data}", "--instance", inter.instance_id,
                 "--out", str(out), "--mode", mode, "--seed", "3"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "synthesized in" in printed and "average distance to the recording" in printed
    track = load_interaction(out / f"{inter.instance_id}_synth.npz")
    assert track.n_frames == inter.n_frames
    np.testing.assert_allclose(track.joints[:10, 1], inter.filled_joints()[:10, 1], atol=1e-9)  # T0 observed frames
    np.testing.assert_array_equal(track.joints[:, 0], inter.joints[:, 0])  # the human is the recording
    assert np.isfinite(track.joints[10:, 1]).all()
    assert (out / f"{inter.instance_id}_synthesis.png").stat().st_size > 1000


def test_synthesize_with_the_paper_preset(
    shake8, shake8_model: SocialAffordanceModel, tmp_path: Path, capsys: pytest.CaptureFixture[str]  # noqa: ANN001
) -> None:
    """``--preset paper`` runs Algorithm 2 as the paper states it (causal, online); it refuses --mode offline."""
    model_path = shake8_model.save(tmp_path / "m.npz")
    inter = shake8[7]
    from socialaff_sim.data import save_dataset

    save_dataset(shake8, tmp_path / "data")
    base = ["synthesize", "--model", str(model_path), "--data", f"npz:{tmp_path / 'data'}", "--instance", inter.instance_id,
            "--seed", "3", "--preset", "paper"]
    assert main([*base, "--out", str(tmp_path / "p")]) == 0
    assert "average distance to the recording" in capsys.readouterr().out
    track = load_interaction(tmp_path / "p" / f"{inter.instance_id}_synth.npz")
    assert np.isfinite(track.joints[10:, 1]).all()
    assert main([*base, "--out", str(tmp_path / "q"), "--mode", "offline"]) == 2
    assert "--preset paper" in capsys.readouterr().err
    assert not (tmp_path / "q").exists()
