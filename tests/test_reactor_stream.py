"""The causal reactor on a stream with bounded work per frame: the canonical track of a growing view
(CanonicalStream) bitwise equal to canonical_joints of the whole lengthened view, frame by frame, with tracking gaps,
a key joint first tracked late and the object held; the evaluation's views from a GrowingInteraction equal to
protocol_view and made without copies; the full method's reactor equal, bitwise, to the same reactor recomputing the
canonical track from the whole view at every call (the path before the stream)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.growing import GrowingInteraction
from socialaff_sim.errors import DataError, ModelError
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference import synthesis
from socialaff_sim.inference.canonical_stream import CanonicalStream
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.protocol import Prediction, observed_part, protocol_view
from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.model.frame import CanonicalFrame
from socialaff_sim.model.handedness import wrist_paths
from socialaff_sim.model.joints import canonical_joints, instance_frame

from test_primitive_stream import _instances

T0 = 10


def _repeat(inst: Interaction, k: int) -> Interaction:
    """``inst`` k times end to end (a stream longer than any training instance)."""
    return inst.replace(joints=np.concatenate([inst.joints] * k), valid=np.concatenate([inst.valid] * k),
                        object=None if inst.object is None else np.concatenate([inst.object] * k), subevents=None)


@pytest.mark.parametrize(("step", "ahead"), [(1, 5), (5, 10), (3, 0)])
def test_canonical_stream_equals_the_whole_view_recomputed(rng: np.random.Generator, step: int, ahead: int) -> None:
    """Every call, the track and the wrist paths equal canonical_joints / wrist_paths of view.extend_held(n) bitwise,
    and the frames before the reported first changed frame are those of the previous call."""
    insts = _instances(rng, 4, gaps=True) + _instances(rng, 2, gaps=True, with_object=False)
    refilled = 0
    for inst in insts:
        stream = None
        for t in range(T0, inst.n_frames, step):
            view = protocol_view(inst, t + 1, T0)
            longer = view.extend_held(t + 1 + ahead)
            stream = stream or CanonicalStream(instance_frame(longer))
            before = stream.track.copy()
            changed = stream.update(view, longer.n_frames)
            ref = canonical_joints(longer, stream.frame)
            assert np.array_equal(stream.track, ref, equal_nan=True)
            assert np.array_equal(stream.paths, wrist_paths(ref, 0))
            keep = min(changed, len(before))
            assert np.array_equal(before[:keep], ref[:keep], equal_nan=True)
            assert changed <= view.n_frames - step or t == T0  # the new frames and the last view's held ones change
            refilled += changed < view.n_frames - step
    assert refilled > 5  # gaps closed (and a joint first tracked late) refilled earlier frames


def test_canonical_stream_work_is_bounded_on_a_long_stream(rng: np.random.Generator) -> None:
    """Without tracking gaps the frames recomputed per frame are the new one and the held ones, however long the
    stream; with gaps, a gap's frames once more when it closes."""
    inst = _repeat(_instances(rng, 1)[0], 6)
    stream = CanonicalStream(CanonicalFrame(origin=np.zeros(3), heading=0.3))
    for t in range(T0, inst.n_frames):
        changed = stream.update(protocol_view(inst, t + 1, T0), t + 6)
        assert stream.n_frames - changed <= 6 or t == T0
    with pytest.raises(ModelError, match="views must grow"):
        stream.update(protocol_view(inst, T0 + 3, T0), T0 + 3)
    # A view lengthened by held frames, whose held frames then become real, is refused (they would not be read).
    held = CanonicalStream(CanonicalFrame(origin=np.zeros(3), heading=0.3))
    held.update(protocol_view(inst, T0 + 1, T0).extend_held(T0 + 4))
    with pytest.raises(ModelError, match="views must grow"):
        held.update(protocol_view(inst, T0 + 5, T0))


def test_growing_views_equal_protocol_views_without_copies(rng: np.random.Generator) -> None:
    inst = _instances(rng, 1, gaps=True)[0]
    hidden = protocol_view(inst, inst.n_frames, T0)
    grow = GrowingInteraction(hidden, capacity=4)
    views = []
    for visible in range(T0 + 1, inst.n_frames + 1):
        grow.append_from(hidden, visible)
        view = grow.view()
        assert view.same_as(protocol_view(inst, visible, T0))
        assert not view.joints.flags.writeable and not view.valid.flags.writeable
        views.append(view)
    # Earlier views keep their frames (the buffer grew under them) and share memory with the buffer: no copy.
    assert views[0].same_as(protocol_view(inst, T0 + 1, T0))
    assert np.shares_memory(views[-1].joints, grow._joints)
    # Frames appended by hand are checked as Interaction checks them.
    bad = hidden.joints[:2].copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(DataError, match="non-finite"):
        grow.append(bad, np.ones(bad.shape[:3], bool), hidden.object[:2])
    with pytest.raises(DataError, match="object"):
        grow.append(hidden.joints[:2], None, None)
    grow.append(hidden.joints[:2], np.asarray(hidden.valid[:2]), hidden.object[:2])
    assert grow.n_frames == inst.n_frames + 2


class _FullView:
    """The canonical track recomputed from the whole lengthened view at every call, everything reported changed
    (the synthesizer's path before CanonicalStream)."""

    def __init__(self, frame: CanonicalFrame) -> None:
        self.frame = frame

    def pin(self, frame: int) -> None:
        pass  # every frame is held

    def update(self, view: Interaction, n_frames: int | None = None, *, keep_from: int = 0) -> int:
        self.track = canonical_joints(view.extend_held(n_frames or view.n_frames), self.frame)
        self.paths = wrist_paths(self.track, 0)
        return 0


def _run(method: AffordanceMethod, inst: Interaction, protocol: str) -> Prediction:
    return run_protocol(method, inst, protocol=protocol, n_observed=T0, rng=np.random.default_rng(3))


@pytest.mark.parametrize("gaps", [False, True])
def test_the_reactor_equals_the_whole_view_recomputed(shake8, monkeypatch: pytest.MonkeyPatch, gaps: bool) -> None:  # noqa: ANN001
    """The full method's causal and paper-protocol predictions, bitwise equal to those of the same reactor whose
    synthesizer recomputes the canonical track from the whole view at every call (and so compares the whole
    history for changes), on synthetic handshakes and on instances with tracking gaps and a stream 3× longer."""
    data = _instances(np.random.default_rng(2), 7, gaps=True) if gaps else list(shake8)
    cfg = SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1, inner_folds=2)
    m = AffordanceMethod("full", learning=LearningConfig(iterations=1), reaction=cfg).fit(data[:4], rng=np.random.default_rng(0))
    tests = [(data[5], "causal"), (data[6], "paper"), (_repeat(data[4], 3), "causal")]
    new = [_run(m, inst, protocol) for inst, protocol in tests]
    # A live loop: frames appended one at a time (checked on the way in), the reactor asked for each as it arrives.
    inst = observed_part(tests[0][0], T0)
    live = GrowingInteraction(inst)
    reactor = m.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
    for t in range(T0, inst.n_frames):
        lo = 0 if t == T0 else t
        live.append(inst.joints[lo : t + 1], np.asarray(inst.valid)[lo : t + 1],
                    None if inst.object is None else inst.object[lo : t + 1])
        assert np.array_equal(reactor.react(live.view(), t, t + 1).joints[0], new[0].joints[t])
    monkeypatch.setattr(synthesis, "CanonicalStream", _FullView)
    old = [_run(m, inst, protocol) for inst, protocol in tests]
    for a, b in zip(new, old, strict=True):
        assert np.array_equal(a.joints, b.joints, equal_nan=True)
        assert np.array_equal(a.key_joints, b.key_joints, equal_nan=True)
        assert np.array_equal(a.subevents, b.subevents)
    assert np.isfinite(new[2].joints[T0:]).any()
