"""scripts/slip_table.py: the two foot meters' medians and counts within the target per interaction, episodes
without a contact phase left out, and the check that an older run's slide is the same episode by episode."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import load_script

table = load_script("slip_table")


def _row(label: str, i: int, slide: float, slip: float, skim: float = 0.0, contact: int = 10, steps: int = 0) -> dict:
    return {"robot": "ours", "mode": "standing", "label": label, "instance": f"{label}_{i:03d}", "contact_frames": contact,
            "foot_slide_cm": slide, "foot_slip_cm": slip, "foot_skim_cm": skim, "foot_skims": int(skim > 0),
            "foot_steps": steps, "foot_step_cm": 5.0 * steps}


def test_medians_and_counts_within_the_target_leave_out_episodes_without_a_contact_phase() -> None:
    rows = [_row("a", 0, 1.0, 0.5), _row("a", 1, 3.0, 1.5, skim=1.0, steps=1), _row("a", 2, 9.0, 8.0),
            _row("a", 3, 50.0, 50.0, contact=0)]
    s = table.summary(rows, 2.0)
    assert s["n"] == 3 and s["slide_median"] == 3.0 and s["slip_median"] == 1.5
    assert s["slide_within"] == 1 and s["slip_within"] == 2 and s["slip_skim_within"] == 1  # 1.5 + 1.0 > 2
    assert s["steps"] == 1 and s["step_cm"] == 5.0 and s["skims"] == 1
    assert s["slip_share"] == pytest.approx(10.0 / 13.0)
    assert table.summary([_row("a", 0, 1.0, 0.5, contact=0)], 2.0) == {"n": 0}


def test_an_older_runs_slide_is_checked_episode_by_episode(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    run = tmp_path / "run.json"
    run.write_text(json.dumps({"rows": [_row("a", 0, 1.0, 0.5), _row("a", 1, 3.0, 1.5)]}))
    ref = tmp_path / "ref.json"
    old = [_row("a", 0, 1.0, 0.5), _row("a", 1, 3.0000001, 1.5), _row("a", 2, 1.0, 1.0)]
    for r in old:
        del r["foot_slip_cm"]
    ref.write_text(json.dumps({"rows": old}))
    table.main([str(run), "--same-slide", str(ref), "--pairs"])
    out = capsys.readouterr().out
    assert "2 shared episodes, 1 differ: a_001" in out and "a_000" in out
