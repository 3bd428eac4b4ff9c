"""The contact sheet shows the moments the sub-goals' flags change (issue 25: "the sheets' flags agree with what
is visible"): the frame choice against a brute-force reference, and a recorded episode's sheet."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import RenderingUnavailableError
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.video import EpisodeRecorder, sheet_frames


def _reference(n: int, k: int, moments: list[int]) -> list[int]:
    """Brute force: each moment in turn replaces the free even frame of least distance (ties: the earlier)."""
    chosen = sorted({round(i * (n - 1) / (k - 1)) for i in range(k)}) if k > 1 else [0]
    fixed = [0, n - 1]
    for m in sorted(set(moments)):
        if m not in chosen:
            best = None
            for f in chosen:
                if f in fixed:
                    continue
                if best is None or abs(f - m) < abs(best - m) or (abs(f - m) == abs(best - m) and f < best):
                    best = f
            if best is not None:
                chosen.remove(best)
            chosen.append(m)
        fixed.append(m)
    return sorted(chosen)


def test_even_frames_without_moments() -> None:
    assert sheet_frames(54, 8, []) == [0, 8, 15, 23, 30, 38, 45, 53]


def test_a_moment_replaces_the_nearest_even_frame() -> None:
    # the high five touched first at frame 45 of 55: it was not on the sheet (46 was); now it is, in 46's place
    got = sheet_frames(55, 8, [45])
    assert 45 in got and 46 not in got and len(got) == 8 and got[0] == 0 and got[-1] == 54
    assert sheet_frames(54, 8, [38]) == sheet_frames(54, 8, [])  # already shown: nothing replaced


def test_first_and_last_frames_and_moments_are_kept() -> None:
    got = sheet_frames(10, 3, [1, 2, 8])  # even: 0, 4(5), 9; only one free slot, then additions
    assert got[0] == 0 and got[-1] == 9 and {1, 2, 8} <= set(got)


def test_against_brute_force() -> None:
    rng = np.random.default_rng(0)
    for _ in range(300):
        n = int(rng.integers(2, 80))
        k = int(rng.integers(2, 10))
        moments = rng.integers(0, n, size=int(rng.integers(0, 5))).tolist()
        assert sheet_frames(n, k, moments) == _reference(n, k, moments), (n, k, moments)


def test_recorded_sheet_holds_the_first_touching_frame(tmp_path: Path) -> None:
    inter = generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands",),
                                                            instances_per_interaction=1))[0]
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    try:
        rec = EpisodeRecorder(sim, None, tmp_path / "s.png", width=96, height=72, n_sheet=4)
    except RenderingUnavailableError as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    with rec:
        run_episode(sim, GroundTruthSource(), inter, on_frame=rec)
    touching = [r.frame for r in sim.results if any(r.subgoals_now.values())]
    achieved = [r.frame for r in sim.results if any(r.subgoals.values())]
    assert touching and achieved  # the ground-truth handshake touches (else this test shows nothing)
    assert rec.moments[:2] == sorted({touching[0], achieved[0]})[:2]
    assert len(rec.sheet_frames) == 4
    shown = sheet_frames(inter.n_frames, 4, rec.moments)
    assert touching[0] in shown and achieved[0] in shown
