"""The record of the Metropolis-Hastings chain (``model.history_``), its log lines and the fit CLI's summary."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.npz_format import save_dataset
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.history import acceptance_rates, new_history, summary_line
from socialaff_sim.learning.mh import MOVES
from socialaff_sim.learning.estimator import SocialAffordanceModel


def test_history_counts_every_proposal(shake8: Dataset, caplog: pytest.LogCaptureFixture) -> None:
    inters = list(shake8)[:4]
    with caplog.at_level(logging.DEBUG, logger="socialaff_sim.learning.algorithm"):
        m = SocialAffordanceModel(learning=LearningConfig(iterations=4, init_type_passes=0, init_rounds=2)).fit(
            inters, rng=np.random.default_rng(0)
        )
    h = m.history_
    proposed = sum(h[f"proposed_{mv}"] for mv in MOVES)
    accepted = sum(h[f"accepted_{mv}"] for mv in MOVES)
    np.testing.assert_array_equal(proposed, np.full(4, len(inters)))  # one proposal per instance and iteration
    np.testing.assert_allclose(accepted / len(inters), m.acceptance_)
    for mv in MOVES:
        assert (h[f"accepted_{mv}"] <= h[f"proposed_{mv}"]).all()
        assert m.moves_[mv] == (int(h[f"proposed_{mv}"].sum()), int(h[f"accepted_{mv}"].sum()))
    np.testing.assert_array_equal(h["log_posterior"], m.trace_)
    np.testing.assert_allclose(h["temperature"], 1000.0 ** np.array([1, 2 / 3, 1 / 3, 0]))
    debug = [r for r in caplog.records if r.levelno == logging.DEBUG and "iteration" in r.getMessage()]
    info = [r for r in caplog.records if r.levelno == logging.INFO and "MH moves accepted" in r.getMessage()]
    assert len(debug) == 4 and len(info) == 1


def test_summary_line() -> None:
    h = new_history(2, -10.0)
    h["proposed_merge"][:] = [3, 1]
    h["accepted_merge"][:] = [1, 0]
    h["proposed_split"][:] = [0, 2]
    h["log_posterior"][1:] = [-8.0, -7.5]
    assert acceptance_rates(h) == {"merge": (4, 1, 0.25), "split": (2, 0, 0.0)}
    assert summary_line(h) == "MH moves accepted: merge 1/4 (25.0%), split 0/2 (0.0%); log P* -10.0 -> -7.5"


def test_cli_fit_prints_the_chain_summary_and_takes_the_paper_preset(
    tmp_path, shake8: Dataset, capsys: pytest.CaptureFixture[str]  # noqa: ANN001
) -> None:
    from socialaff_sim.cli.main import main

    save_dataset(Dataset("small", tuple(shake8)[:4]), tmp_path / "data")
    out = tmp_path / "model.npz"
    args = ["fit", "--data", f"npz:{tmp_path / 'data'}", "--interaction", "shake_hands", "--out", str(out),
            "--iterations", "2", "--no-progress"]
    assert main([*args, "--preset", "paper"]) == 0
    text = capsys.readouterr().out
    assert "with the paper preset" in text and "MH moves accepted:" in text
    assert "shift" not in text.split("MH moves accepted:")[1].split(";")[0]
    loaded = SocialAffordanceModel.load(out)
    assert not loaded.config.path_noise and loaded.config.reference_self and not loaded.config.unique_labels
    assert main([*args, "--preset", "nope"]) == 2
    assert "--preset" in capsys.readouterr().err
