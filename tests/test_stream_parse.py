"""The online parse on long streams: work bounded by the window, equal to the unbounded parse where
the window covers the stream, cached scores equal to fresh ones, deterministic per seed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import load_script

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.interaction import Interaction
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig, parse_prefix
from socialaff_sim.inference.stream_parse import StreamParser
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.learning.atomic import cut_atoms
from socialaff_sim.model.handedness import left_active, wrist_paths
from socialaff_sim.model.joints import canonical_joints, instance_frame


def _stream(parts: list[Interaction], n_frames: int) -> Interaction:
    """``parts`` end to end (cycled) cut to ``n_frames`` frames: a stream longer than any recording."""
    reps = -(-n_frames // sum(p.n_frames for p in parts))
    seq = parts * reps
    return parts[0].replace(
        joints=np.concatenate([p.joints for p in seq])[:n_frames],
        valid=np.concatenate([np.isfinite(p.joints).all(axis=-1) if p.valid is None else p.valid for p in seq])[:n_frames],
        object=None, subevents=None, subevent_names=(), instance_id="stream",
    )


def _run(model: SocialAffordanceModel, inter: Interaction, cfg: SynthesisConfig, seed: int):  # noqa: ANN202
    """Key joints (T, 5, 3), sub-events (T,), beliefs (T, S) and the parse counts of every re-planning."""
    syn = OnlineSynthesizer(model, None, cfg)
    syn.reset(inter, rng=np.random.default_rng(seed))
    keys, subs, beliefs, work = [], [], [], []
    parses = 0
    for _ in range(inter.n_frames):
        t = syn.t
        step = syn.step()
        keys.append(step.key_joints)
        subs.append(step.subevent)
        beliefs.append(step.belief)
        w = syn.work
        if w is not None and w.totals.get("parses", 0) > parses:
            parses = w.totals["parses"]
            work.append((t, w.frames, w.cuts, w.dp_rows, w.dp_cells, w.scored, w.cached))
    return np.array(keys), np.array(subs), np.array(beliefs), np.array(work)


@pytest.fixture(scope="module")
def stream(shake8: Dataset) -> Interaction:
    return _stream(list(shake8)[6:], 300)


def test_work_per_parse_is_bounded_by_the_window(shake8_model: SocialAffordanceModel, stream: Interaction) -> None:
    S = shake8_model.n_subevents_
    W, H = 30, 15  # frames: parse_window 1 s at 30 Hz, and its hop
    cfg = SynthesisConfig.reactive(belief="argmax", parse_window=W / stream.fps)
    _, _, _, work = _run(shake8_model, stream, cfg, 0)
    t, frames, cuts, rows, cells, scored, cached = work.T
    F = W + H - 1  # the longest window
    M = 1 << S if shake8_model.config.unique_labels else 1
    assert t.max() > 5 * F  # the stream runs well past the window
    assert frames.max() == F and frames[t >= W + H].min() == W
    assert cuts.max() <= F + 1 and rows.max() <= F and cells.max() <= F * F * M * S * S
    assert scored.max() <= F * (F - 1) // 2 and cached.max() <= F * (F - 1) // 2  # pairs of cuts in the window
    assert rows.sum() < 0.5 * (cuts - 1).sum()  # most DP rows are reused from the previous parse
    # The unbounded parse (the paper's) reads every frame since the start: its work grows with t.
    _, _, _, full = _run(shake8_model, stream, dataclasses.replace(cfg, parse_window=None), 0)
    assert full[-1, 1] == full[-1, 0] > 5 * F and full[-1, 2] > 2 * (F + 1)


def test_window_covering_the_stream_equals_the_unbounded_parse(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    inter = _stream(list(shake8)[6:], 140)
    for base in (SynthesisConfig.reactive(belief="argmax"), SynthesisConfig(belief="argmax")):
        a = _run(shake8_model, inter, dataclasses.replace(base, parse_window=None), 3)
        b = _run(shake8_model, inter, dataclasses.replace(base, parse_window=inter.n_frames / inter.fps), 3)
        for x, y in zip(a[:3], b[:3]):
            np.testing.assert_array_equal(x, y)


def test_cached_scores_equal_a_fresh_parse_of_the_whole_prefix(shake8_model: SocialAffordanceModel, stream: Interaction) -> None:
    model = shake8_model
    track = canonical_joints(stream, instance_frame(stream))[:160]
    lc = model.learning
    atoms = dict(min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds)
    parser = StreamParser(model, stream.fps, None, **atoms)
    fresh = 0
    for t in range(12, 160, 7):
        got, w0 = parser.parse(track, t, model.available_)
        bounds = cut_atoms(track[:t], stream.fps, model.available_, model.centroids_, **atoms)
        ref = parse_prefix(model, track[:t], stream.fps, bounds)  # scored from scratch
        fresh += (len(bounds) - 1) * (len(bounds) - 2) // 2  # closed intervals a fresh parse scores
        assert w0 == 0
        np.testing.assert_array_equal(got.intervals, ref.intervals)
        np.testing.assert_allclose(got.belief, ref.belief, rtol=1e-9, atol=1e-12)
    assert parser.work.totals["scored"] < fresh / 3  # most scores came from the cache


def test_windowed_parse_rows_are_absolute_and_cover_the_window(shake8_model: SocialAffordanceModel, stream: Interaction) -> None:
    model = shake8_model
    track = canonical_joints(stream, instance_frame(stream))
    lc = model.learning
    parser = StreamParser(model, stream.fps, 40, min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds,
                          tau=lc.velocity_seconds)
    for t in (30, 40, 59, 60, 61, 120, 299):
        parse, w0 = parser.parse(track, t, model.available_)
        assert w0 == (0 if t < 60 else (t - 40) // 20 * 20) and 40 <= t - w0 < 60 or t < 40
        rows = parse.intervals
        assert rows[0, 0] == w0 and rows[-1, 1] == t and np.all(rows[1:, 0] == rows[:-1, 1])
        assert all(key[0] >= w0 for key in parser._scores)
        np.testing.assert_allclose(parse.belief.sum(), 1.0)


def test_same_seed_same_stream_synthesis(shake8_model: SocialAffordanceModel, stream: Interaction) -> None:
    cfg = SynthesisConfig.reactive(belief="argmax", parse_window=1.0)
    a = _run(shake8_model, stream, cfg, 7)
    b = _run(shake8_model, stream, cfg, 7)
    c = _run(shake8_model, stream, cfg, 8)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[0], c[0])


@pytest.mark.parametrize("window", [0.0, -1.0])
def test_parse_window_must_be_positive(window: float) -> None:
    with pytest.raises(ConfigError, match="parse_window"):
        SynthesisConfig(belief="argmax", parse_window=window)


def test_running_wrist_paths_give_the_causal_hand_flag(rng: np.random.Generator) -> None:
    track = np.cumsum(rng.normal(0.0, 0.02, (200, 11, 3)), axis=0)
    track[rng.random(200) < 0.1, 1] = np.nan  # missing left-wrist frames add nothing
    paths = wrist_paths(track, 0)
    for stop in (0, 1, 2, 17, 100, 200):
        k = max(stop, 1) - 1
        ref = np.nansum(np.linalg.norm(np.diff(track[:stop, 1:3], axis=0), axis=-1), axis=0) if stop > 1 else np.zeros(2)
        np.testing.assert_allclose(paths[k], ref, rtol=1e-12, atol=1e-12)
        for margin in (0.0, 0.05, abs(ref[0] - ref[1]) + 1e-6):
            assert (paths[k, 0] - paths[k, 1] > margin) == left_active(track, 0, stop, margin)


def test_incremental_windowed_parse_equals_a_fresh_one(shake8_model: SocialAffordanceModel, stream: Interaction) -> None:
    model = shake8_model
    track = canonical_joints(stream, instance_frame(stream))
    lc = model.learning
    atoms = dict(min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds)
    parser = StreamParser(model, stream.fps, 40, **atoms)
    reused = 0
    for t in range(12, 300, 3):
        got, w0 = parser.parse(track, t, model.available_)
        reused += parser.work.cuts - 1 - parser.work.dp_rows
        ref, r0 = StreamParser(model, stream.fps, 40, **atoms).parse(track, t, model.available_)  # no cache, no rows
        assert w0 == r0
        np.testing.assert_array_equal(got.intervals, ref.intervals)
        np.testing.assert_allclose(got.belief, ref.belief, rtol=1e-9, atol=1e-12)
    assert reused > 0


def test_bench_stream_script_records_latency_per_part(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    bench = load_script("bench_stream")
    inter = bench.concatenate(list(shake8)[6:], 150, "s")
    assert inter.n_frames == 150 and np.array_equal(inter.joints[: shake8[6].n_frames], shake8[6].joints, equal_nan=True)
    out = bench.run_stream(shake8_model, inter, SynthesisConfig.reactive(belief="argmax", parse_window=1.0), seed=0, parts=3)
    assert [p["span"] for p in out["parts"]] == [[0, 50], [50, 100], [100, 150]]
    assert sum(p["frames"] for p in out["parts"]) == 150 - SynthesisConfig().n_observed == out["frames"]
    assert out["parse_totals"]["parses"] > 0 and out["n_frames"] == 150 and out["belief_rows_max"] == 0
    fwd = bench.run_stream(shake8_model, inter, SynthesisConfig.reactive(belief_horizon=2.0), seed=0, parts=3)
    assert fwd["parse_totals"] == {} and 0 < fwd["belief_rows_max"] <= -(-round(2.0 * inter.fps) // 2)
