"""Fit progress: a callback after the initial parse and every MCMC iteration, the same on the logger, and the CLI bar."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.cli.main import main
from socialaff_sim.data import save_dataset
from socialaff_sim.learning import FitProgress, LearningConfig
from socialaff_sim.learning import SocialAffordanceModel


def test_callback_and_log_follow_the_chain(shake8, caplog: pytest.LogCaptureFixture) -> None:  # noqa: ANN001
    seen: list[FitProgress] = []
    caplog.set_level(logging.INFO, logger="socialaff_sim.learning.algorithm")
    model = SocialAffordanceModel(learning=LearningConfig(iterations=3)).fit(
        list(shake8)[:5], rng=np.random.default_rng(0), callback=seen.append
    )
    assert [p.iteration for p in seen] == [0, 1, 2, 3] and {p.iterations for p in seen} == {3}
    np.testing.assert_allclose([p.log_posterior for p in seen], model.trace_)  # the chain's state after each sweep
    best = [p.best_log_posterior for p in seen]
    assert all(b >= lp for b, lp in zip(best, model.trace_, strict=True)) and np.all(np.diff(best) >= 0)
    assert best[-1] == pytest.approx(model.log_posterior_)
    assert seen[-1].acceptance == pytest.approx(model.acceptance_rate_)
    assert all(p.label == "shake_hands" for p in seen) and np.all(np.diff([p.seconds for p in seen]) >= 0)
    lines = [r.getMessage() for r in caplog.records if r.name == "socialaff_sim.learning.algorithm"]
    assert any("initial parse" in m for m in lines)
    assert [m.split(",")[0] for m in lines if "iteration" in m] == [f"shake_hands: iteration {k}/3" for k in range(4)]


def test_cli_fit_reports_its_stages(shake8, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    save_dataset(shake8.subset([i.instance_id for i in list(shake8)[:3]]), tmp_path / "data")
    assert main(["fit", "--data", f"npz:{tmp_path / 'data'}", "--interaction", "shake_hands", "--iterations", "1",
                 "--out", str(tmp_path / "a.npz")]) == 0
    printed = capsys.readouterr()
    assert "on 3 instances" in printed.err and "then 1 MCMC iterations" in printed.err
    assert "next: socialaff-sim show" in printed.out
