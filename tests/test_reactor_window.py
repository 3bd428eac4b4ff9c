"""The causal reactor's memory in a bounded window (issue 24): TrackWindow against a plain array; the canonical stream
with a window against the unbounded one, bitwise, through tracking gaps of agent 0's wrists that open before the window
(and over the pinned hold frame) and close inside it; the full method's reactor on a stream many windows long, bitwise
equal to the unbounded reactor (forward belief, and the windowed arg-max parse); the state flat; readers asking for a
frame older than the window get an error."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.growing import GrowingInteraction
from socialaff_sim.errors import ModelError
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference import canonical_stream
from socialaff_sim.inference.canonical_stream import CanonicalStream
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.protocol import observed_part, protocol_view
from socialaff_sim.inference.stream_parse import StreamParser
from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig
from socialaff_sim.inference import synthesis
from socialaff_sim.inference.track_window import TrackWindow
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.model.frame import CanonicalFrame
from socialaff_sim.model.joints import canonical_joints, instance_frame

from conftest import swap_sides
from test_primitive_stream import _instances
from test_reactor_stream import _repeat

T0 = 10


def test_track_window_matches_an_array_and_refuses_forgotten_frames(rng: np.random.Generator) -> None:
    """Random extends, forgets and writes: every frame held reads as in a plain array; a frame below the floor raises
    (but the pinned one); the buffer stays within twice the frames held (or the minimum capacity)."""
    ref = np.full((0, 3, 2), np.nan)
    win = TrackWindow((3, 2), name="w", capacity=4)
    win.pin(3)
    floor = 0
    for step in range(400):
        n = ref.shape[0] + int(rng.integers(0, 4))
        ref = np.concatenate([ref, np.full((n - ref.shape[0], 3, 2), np.nan)])
        win.extend(n)
        if n and rng.random() < 0.7:
            a = int(rng.integers(floor, n))
            b = int(rng.integers(a, n + 1))
            val = rng.normal(size=(b - a, 3, 2))
            ref[a:b] = val
            win[a:b] = val
        if n > 3 and rng.random() < 0.3 and floor <= 3 < n:
            ref[3, 1] = step
            win[3, 1] = step
        floor = max(floor, n - int(rng.integers(5, 20)), 0)
        win.forget(floor)
        assert win.floor == min(floor, n) and win.shape == ref.shape
        assert np.array_equal(win.rows, ref[win.floor :], equal_nan=True)
        if n:
            k = np.arange(win.floor, n)
            assert np.array_equal(win[k, 1], ref[k, 1], equal_nan=True)
        if n > 3:
            assert np.array_equal(win[3], ref[3], equal_nan=True)  # pinned: readable below the floor too
        assert win.capacity <= 2 * 23
    assert win.floor > 100
    with pytest.raises(ModelError, match="older than the window"):
        win[win.floor - 1]
    with pytest.raises(ModelError, match="older than the window"):
        win[np.array([win.floor - 1, win.floor])]
    with pytest.raises(ModelError, match="before the window"):
        win[win.floor - 2 : win.floor + 1]
    with pytest.raises(ModelError, match="forgotten"):
        np.asarray(win)
    f, n = win.floor, win.n
    assert np.array_equal(win[f : n : 1], win[f:n], equal_nan=True)  # a unit step reads as no step
    with pytest.raises(ModelError, match="with a step"):
        win[f : n : 2]
    with pytest.raises(ModelError, match="negative frames"):
        win[-1 : n]
    assert win[n - 1 : f].shape == (0, 3, 2) and win[n : n + 5].shape == (0, 3, 2)  # empty, clipped at n
    win.map(lambda x: -x)  # the pinned row too
    assert np.array_equal(win[3], -ref[3], equal_nan=True)
    assert np.array_equal(win.rows, -ref[win.floor :], equal_nan=True)


def _gapped_stream(rng: np.random.Generator, k: int) -> Interaction:
    """Reaching instances end to end with agent 0's wrists untracked over long runs: one over the hold frame T0 − 1,
    closing after the window has passed it, one opening early and closing late, one up to a frame of a later view."""
    inst = _repeat(_instances(rng, 1, gaps=True)[0], k)
    valid = np.array(inst.valid, copy=True)
    valid[5:70, 0, 2] = False  # over T0 - 1
    valid[100:260, 0, 1] = False  # longer than the window
    valid[300:330, 0, 1] = False  # shorter
    valid[340:420, 0, 1:3] = False  # both wrists at once
    return inst.replace(valid=valid)


@pytest.mark.parametrize("chunk", [4096, 7])
def test_canonical_stream_window_equals_the_unbounded_stream(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch,
                                                             chunk: int) -> None:
    """Every call: the frames held, the wrist paths held and the pinned frame equal the unbounded stream's bitwise, the
    first changed frame too; gaps opening before the window closed (their sums carried), the pinned frame refilled."""
    monkeypatch.setattr(canonical_stream, "_CHUNK", chunk)
    inst = _gapped_stream(rng, 14)
    L = 40
    frame = CanonicalFrame(origin=np.array([0.1, -0.2, 0.0]), heading=0.7)
    full, win = CanonicalStream(frame), CanonicalStream(frame)
    win.pin(T0 - 1)
    carried, pinned_refill = 0, 0
    for t in range(T0, inst.n_frames):
        view = protocol_view(inst, t + 1, T0)
        before = win.track[T0 - 1].copy() if win.n_frames else None
        c_full = full.update(view, t + 6)
        c_win = win.update(view, t + 6, keep_from=max(t - L, 0))
        assert c_full == c_win
        f = win.floor
        assert f == max(t - L, 0)
        assert np.array_equal(win.track.rows, np.asarray(full.track)[f:], equal_nan=True)
        assert np.array_equal(win.paths.rows, np.asarray(full.paths)[f:])
        assert np.array_equal(win.track[T0 - 1], np.asarray(full.track)[T0 - 1], equal_nan=True)
        carried += bool(win._carry)
        pinned_refill += before is not None and f > T0 and not np.array_equal(before, win.track[T0 - 1], equal_nan=True)
    assert carried >= 3 and pinned_refill == 1  # both events happened
    assert win.track.capacity <= 2 * (L + 7) + 2
    with pytest.raises(ModelError, match="older than the window"):
        win.track[win.floor - 1]


def test_readers_refuse_frames_older_than_the_window(shake8, shake8_model) -> None:  # noqa: ANN001
    """The forward belief and the windowed parse, handed a window that starts after a frame they read, raise."""
    inst = list(shake8)[6]
    track = canonical_joints(inst, instance_frame(inst))
    fb = ForwardBelief(shake8_model, inst.fps, stride=3, horizon=12)
    fb.advance(track, 30)
    short = TrackWindow.of(track)
    short.forget(25)
    with pytest.raises(ModelError, match="older than the window|before the window|holds frames from 25"):
        fb.advance(short, 40)  # the next cut reads back to its horizon: frame 17 or so
    ok = ForwardBelief(shake8_model, inst.fps, stride=3, horizon=12)
    ok.advance(track, 30)
    held = TrackWindow.of(track)
    held.forget(12)
    ok.advance(held, 40)  # the window holds what the cuts read: the same posterior as unwindowed
    ref = ForwardBelief(shake8_model, inst.fps, stride=3, horizon=12)
    ref.advance(track, 40)
    assert all(np.array_equal(a, b) for a, b in zip(ok.posterior(40), ref.posterior(40), strict=True))
    lc = shake8_model.learning
    atoms = dict(min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds)
    parser = StreamParser(shake8_model, inst.fps, 20, **atoms)
    t = 50  # w0 = 30: the parse reads frames from 29
    with pytest.raises(ModelError, match="holds frames from 30"):
        parser.parse(track[30:], t, shake8_model.available_, offset=30)
    got, w0 = StreamParser(shake8_model, inst.fps, 20, **atoms).parse(track[29:], t, shake8_model.available_, offset=29)
    want, r0 = StreamParser(shake8_model, inst.fps, 20, **atoms).parse(track, t, shake8_model.available_)
    assert w0 == r0 == 30 and np.array_equal(got.intervals, want.intervals) and np.array_equal(got.belief, want.belief)


@pytest.fixture(scope="module")
def window_method(shake8) -> AffordanceMethod:  # noqa: ANN001
    cfg = SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1, inner_folds=2)
    return AffordanceMethod("full", learning=LearningConfig(iterations=1), reaction=cfg).fit(list(shake8)[:4], rng=np.random.default_rng(0))


def _long_stream(shake8, k: int) -> Interaction:  # noqa: ANN001
    """Handshakes end to end, every other one with agent 0's sides swapped (the active hand flips), with long gaps of
    agent 0's wrists (one over the hold frame)."""
    a, b = list(shake8)[5], swap_sides(list(shake8)[6], (0,))
    parts = [a if i % 2 == 0 else b for i in range(k)]
    inst = a.replace(joints=np.concatenate([p.joints for p in parts]), valid=np.concatenate([np.asarray(p.valid) for p in parts]),
                     subevents=None)
    valid = np.array(inst.valid, copy=True)
    wrists = inst.layout.key_indices[1:3]  # agent 0's wrists among the model joints 1 and 2
    valid[4:150, 0, wrists[1]] = False  # over T0 - 1, closing after the window passed it
    valid[300:520, 0, wrists[0]] = False  # longer than the window
    return inst.replace(valid=valid)


@pytest.mark.parametrize("belief", ["forward", "argmax"])
def test_the_reactor_in_its_window_equals_the_unbounded_reactor(shake8, window_method: AffordanceMethod,  # noqa: ANN001
                                                                 monkeypatch: pytest.MonkeyPatch, belief: str) -> None:
    """On a stream over ten windows long with the active hand flipping and wrist gaps opening before the window, the
    causal prediction (skeletons, key joints, sub-events), frame by frame, is bitwise that of the same reactor holding
    every frame; the window was in force (floor > 0, buffers bounded), the gaps' sums carried, the hold frame pinned."""
    m = window_method
    m.synthesis = dataclasses.replace(m.synthesis, belief=belief, parse_window=2.0, belief_horizon=2.0)
    inst = _long_stream(shake8, 12)
    with monkeypatch.context() as patch:
        patch.setattr(synthesis, "reader_window", lambda *args: None)
        ref = run_protocol(m, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3))
    reactor = m.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
    hidden = observed_part(inst, T0)
    views = GrowingInteraction(hidden)
    flips, carried, last = 0, 0, None
    for t in range(T0, inst.n_frames):
        views.append_from(hidden, t + 1)
        p = reactor.react(views.view(), t, t + 1)
        assert np.array_equal(p.joints[0], ref.joints[t], equal_nan=True)
        assert np.array_equal(p.key_joints[0], ref.key_joints[t], equal_nan=True)
        assert p.subevents[0] == ref.subevents[t]
        syn = reactor.synths[0]
        flips += last is not None and not np.array_equal(syn._hands, last)
        carried += bool(syn._view._carry)
        last = syn._hands.copy()
    L = syn.window
    assert L is not None and inst.n_frames > 10 * L
    assert syn._track.floor == inst.n_frames - 1 - L and syn._view.floor == syn._track.floor
    cap = 2 * (L + syn.config.delta_t + 2)
    assert syn._track.capacity <= cap and syn._view.track.capacity <= cap and syn._view.paths.capacity <= cap
    assert flips >= 1 and carried >= 2  # relabelled and gaps closed with the window in force
