"""scripts/judge_support.py: the pairing of two bench_support runs, the lost and gained episodes, and the paired
bootstrap against a resample-by-resample brute force; a bad file gives a one-line error naming it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import load_script

judge = load_script("judge_support")


def _row(label: str, i: int, success: bool, support: float, slide: float, contact: int = 10,
         failures: tuple[str, ...] = (), mode: str = "standing") -> dict:
    return {"robot": "ours", "mode": mode, "label": label, "instance": f"{label}_{i:03d}", "success": success,
            "contact_frames": contact, "failures": list(failures), "outside_support_mean": support,
            "foot_slide_cm": slide, "episode_tilt_deg_max": 3.0 + i}


def _write(path: Path, rows: list[dict]) -> str:
    path.write_text(json.dumps({"config": {}, "rows": rows}))
    return str(path)


def test_bootstrap_matches_a_brute_force_resampling() -> None:
    d = np.random.default_rng(3).normal(0.5, 2.0, size=17)
    mean, lo, hi = judge.bootstrap(d, np.random.default_rng(11), resamples=2_000)
    idx = np.random.default_rng(11).integers(0, d.size, size=(2_000, d.size))
    brute = sorted(sum(d[j] for j in row) / d.size for row in idx)
    assert mean == pytest.approx(float(np.mean(d)))
    assert lo == pytest.approx(np.percentile(brute, 2.5)) and hi == pytest.approx(np.percentile(brute, 97.5))
    assert lo < mean < hi
    assert all(np.isnan(judge.bootstrap(np.array([]), np.random.default_rng(0))))


def test_episodes_are_paired_by_key_and_lost_and_gained_are_told_apart(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    a = [_row("high_five", 1, True, 0.02, 1.0), _row("high_five", 2, False, 0.04, 3.0),
         _row("pull_up", 1, True, 0.10, 5.0), _row("pull_up", 2, True, 0.0, 0.0, contact=0),
         _row("pull_up", 3, True, 0.5, 9.0)]  # only in A: not paired
    b = [_row("pull_up", 1, True, 0.06, 4.0, failures=("object_dropped",)), _row("high_five", 2, True, 0.05, 2.0),
         _row("high_five", 1, False, 0.03, 1.5), _row("pull_up", 2, True, 0.01, 0.2)]
    judge.main([_write(tmp_path / "a.json", a), _write(tmp_path / "b.json", b), "--seed", "4"])
    out = capsys.readouterr().out
    assert "paired episodes: 4 (A only 1, B only 0)" in out
    assert "4 episodes, 3 with a contact phase in both" in out  # pull_up_002 has none in A
    assert "lost ['high_five_001']; gained ['high_five_002']" in out
    assert "failures A {}  B {'object_dropped': 1}" in out
    # support B - A over the three: (+1, +1, -4) points; slide (+0.5, -1, -1) cm
    assert "support (points) B-A -0.67" in out and "slide (cm) B-A -0.50" in out
    assert "high_five 1/1 of 2, pull_up 2/2 of 2" in out


def test_filters_pick_one_mode(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    a = [_row("high_five", 1, True, 0.0, 1.0), _row("high_five", 1, True, 0.3, 9.0, mode="harness")]
    b = [_row("high_five", 1, False, 0.0, 1.0), _row("high_five", 1, True, 0.3, 9.0, mode="harness")]
    judge.main([_write(tmp_path / "a.json", a), _write(tmp_path / "b.json", b), "--mode", "harness"])
    out = capsys.readouterr().out
    assert "== ours / harness" in out and "== ours / standing" not in out and "successes 1 -> 1" in out


def test_a_file_without_rows_is_refused_with_its_name(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"config": {}}))
    with pytest.raises(SystemExit) as exc:
        judge.load_rows(str(bad))
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and "bad.json: expected a bench_support.py --json file" in err


def test_outcome_codes_are_counted_only_when_both_runs_have_them(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    a = [_row("high_five", 1, True, 0.0, 1.0) | {"outcome": "success"},
         _row("high_five", 2, False, 0.0, 1.0) | {"outcome": "no_contact"}]
    b = [_row("high_five", 1, False, 0.0, 1.0) | {"outcome": "timeout"},
         _row("high_five", 2, False, 0.0, 1.0) | {"outcome": "no_contact"}]
    judge.main([_write(tmp_path / "a.json", a), _write(tmp_path / "b.json", b)])
    assert "outcomes A {'success': 1, 'no_contact': 1}  B {'timeout': 1, 'no_contact': 1}" in capsys.readouterr().out
    old = [{k: v for k, v in r.items() if k != "outcome"} for r in a]  # a run from before the codes
    judge.main([_write(tmp_path / "a.json", old), _write(tmp_path / "b.json", b)])
    assert "outcomes" not in capsys.readouterr().out


def _framed(row: dict, contact: list[int], support: list[float], slide: list[float]) -> dict:
    return {**row, "frames_contact": contact, "frames_support": support, "frames_slide_cm": slide}


def test_shared_frames_take_only_the_frames_both_arms_touch() -> None:
    rng = np.random.default_rng(5)
    ca, cb = rng.integers(0, 2, 40), rng.integers(0, 2, 40)
    sa, sb, la, lb = (rng.random(40) for _ in range(4))
    ra = _framed(_row("pull_up", 1, True, 0.0, 0.0), ca.tolist(), sa.tolist(), la.tolist())
    rb = _framed(_row("pull_up", 1, True, 0.0, 0.0), cb.tolist(), sb.tolist(), lb.tolist())
    got = judge.shared_frames(ra, rb)
    idx = [i for i in range(40) if ca[i] and cb[i]]  # brute force: frame by frame
    assert got is not None and got[4] == len(idx)
    assert got[0] == pytest.approx(100 * sum(sa[i] for i in idx) / len(idx))
    assert got[1] == pytest.approx(100 * sum(sb[i] for i in idx) / len(idx))
    assert got[2] == pytest.approx(sum(la[i] for i in idx)) and got[3] == pytest.approx(sum(lb[i] for i in idx))


def test_a_longer_contact_in_b_is_not_counted_against_it(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    # A touches in frames 2-3 only; B in 0-5 and slides 5 cm in each of its extra frames: over the shared frames the
    # arms are equal, while the phase-summed slide (the older line) is 20 cm worse
    a = [_framed(_row("hand_over", 1, False, 0.1, 2.0, contact=2), [0, 0, 1, 1, 0, 0], [0.1] * 6, [1.0] * 6)]
    b = [_framed(_row("hand_over", 1, True, 0.1, 22.0, contact=6), [1] * 6, [0.1] * 6, [5.0, 5.0, 1.0, 1.0, 5.0, 5.0])]
    judge.main([_write(tmp_path / "a.json", a), _write(tmp_path / "b.json", b)])
    out = capsys.readouterr().out
    assert "slide (cm) B-A +20.00" in out
    assert "shared contact frames: 1 episodes, 2 frames; support (points) B-A +0.00 [+0.00, +0.00]; slide (cm) B-A +0.00" in out


def test_no_shared_line_without_per_frame_figures_or_shared_frames(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    a = [_row("high_five", 1, True, 0.0, 1.0)]
    judge.main([_write(tmp_path / "a.json", a), _write(tmp_path / "b.json", a)])
    assert "shared contact frames" not in capsys.readouterr().out
    ra = _framed(_row("high_five", 1, True, 0.0, 1.0), [1, 0], [0.0, 0.0], [0.0, 0.0])
    rb = _framed(_row("high_five", 1, True, 0.0, 1.0), [0, 1], [0.0, 0.0], [0.0, 0.0])
    assert judge.shared_frames(ra, rb) is None


def test_bench_rows_carry_per_frame_figures_that_add_up_to_the_phase(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "scripts"))
    bench = load_script("bench_support")
    out = tmp_path / "rows.json"
    monkeypatch.setattr("sys.argv", ["bench_support.py", "--modes", "harness", "--per-label", "1", "--labels",
                                     "shake_hands", "--json", str(out)])
    bench.main()
    (row,) = json.loads(out.read_text())["rows"]
    c = np.asarray(row["frames_contact"], bool)
    assert c.sum() == row["contact_frames"] > 0
    assert len(row["frames_support"]) == len(row["frames_slide_cm"]) == c.size
    assert np.sum(np.asarray(row["frames_slide_cm"])[c]) == pytest.approx(row["foot_slide_cm"], rel=1e-9, abs=1e-9)
    assert np.mean(np.asarray(row["frames_support"])[c]) == pytest.approx(row["outside_support_mean"], rel=1e-9, abs=1e-12)
