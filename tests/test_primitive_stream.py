"""The interaction primitive on a stream (PrimitiveStream): frame by frame equal to the batch causal prediction
(react_keys, which recomputes everything from the view) on data with tracking gaps, an object and a key joint first
tracked late; every frame counts; past the longest training duration the bounded rule (T̂ = T_max, phase clamped
at 1) against the batch conditioning with that duration, with a state that does not grow; determinism."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.data.specs import load_dataset
from socialaff_sim.errors import ModelError
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.protocol import protocol_view
from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig
from socialaff_sim.learning.config import LearningConfig

from conftest import shared_path

T0 = 10
TOL = 1e-9  # metres


def _instances(rng: np.random.Generator, n: int, *, gaps: bool = False, with_object: bool = True) -> list[Interaction]:
    """Agent 0 reaches out with an object along a phase-normalized curve, agent 1 mirrors it; ``gaps``: random
    untracked runs of agent 0's key joints, and its left ankle untracked in the first frames."""
    out = []
    for k in range(n):
        T = int(rng.integers(30, 45))
        s = np.linspace(0, 1, T)
        amp = rng.uniform(0.2, 0.5)
        body0 = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
        body1 = body0 * [-1, -1, 1] + [1.4, 0, 0]
        a0 = np.repeat(body0[None], T, 0) + rng.normal(0, 0.005, (T, 5, 3))
        a1 = np.repeat(body1[None], T, 0) + rng.normal(0, 0.005, (T, 5, 3))
        bump = np.sin(np.pi * s) * amp
        a0[:, 1, 0] += bump
        a1[:, 2, 0] -= bump
        valid = np.ones((T, 2, 5), bool)
        if gaps:
            for _ in range(4):
                j, lo = int(rng.integers(1, 5)), int(rng.integers(2, T - 3))
                valid[lo : lo + int(rng.integers(1, 6)), 0, j] = False
            valid[: int(rng.integers(12, 20)), 0, 3] = False  # first tracked after the view starts
            valid[-2:, 0, 4] = False  # held to the end
        obj = a0[:, 1] + [0.05, 0, 0] if with_object else None
        out.append(Interaction("reach", 10.0, np.stack([a0, a1], 1), KEY_JOINTS, ("p", "q"), object=obj, valid=valid,
                               instance_id=f"r{k:02d}"))
    return out


def _compare(prim: InteractionPrimitive, inst: Interaction, step: int = 1) -> float:
    """Max |stream − batch| (metres) over the causal frames within T_max, in blocks of ``step`` frames (the paper
    protocol's ΔT: frames past the view asked for); asserts the chosen durations agree."""
    stream, worst = PrimitiveStream(prim, T0), 0.0
    for t in range(T0, min(inst.n_frames, stream.t_max - step + 1), step):
        view = protocol_view(inst, t + 1, T0)
        batch = prim.react_keys(view, t, t + step, n_observed=T0)
        got = stream.react_keys(view, t, t + step)
        assert stream.duration == prim.estimate_duration(view, t + step)
        assert np.array_equal(np.isnan(got), np.isnan(batch))
        worst = max(worst, float(np.nanmax(np.abs(got - batch))))
    return worst


@pytest.mark.parametrize("with_object", [True, False])
def test_stream_equals_the_batch_prediction_frame_by_frame(rng: np.random.Generator, with_object: bool) -> None:
    insts = _instances(rng, 9, gaps=True, with_object=with_object)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=6)).fit(insts[3:])
    for inst in insts[:3]:
        assert _compare(prim, inst) < TOL
    assert _compare(prim, insts[0], step=5) < TOL


def test_stream_equals_the_batch_prediction_on_recorded_handovers() -> None:
    root = shared_path("handover_h2h")
    data = [i for i in load_dataset(f"handover:{root}") if i.label == "hand_over"][:24]
    prim = InteractionPrimitive().fit(data[2:])
    for inst in data[:2]:
        assert _compare(prim, inst) < TOL


def test_every_frame_enters_the_running_sums(rng: np.random.Generator) -> None:
    """Moving agent 0 at one earlier frame changes the later prediction, by what the batch says."""
    insts = _instances(rng, 8)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(insts[2:])
    inst = insts[0]
    joints = inst.joints.copy()
    joints[20, 0] += [0.3, -0.2, 0.1]
    moved = inst.replace(joints=joints)
    t = 27
    outs = []
    for x in (inst, moved):
        stream = PrimitiveStream(prim, T0)
        for u in range(T0, t + 1):
            got = stream.keys(protocol_view(x, u + 1, T0), u, u + 1)
        outs.append(got)
        assert np.allclose(got, prim.conditioned_keys(protocol_view(x, t + 1, T0), t, t + 1, n_observed=T0), atol=TOL)
    assert np.nanmax(np.abs(outs[0] - outs[1])) > 1e-4


def test_beyond_the_longest_training_duration_the_work_and_state_are_bounded(rng: np.random.Generator) -> None:
    """Past T_max: T̂ = T_max and later frames are observations at phase 1, against the batch conditioning with
    duration T_max on the whole view; the state's size stays what it was at T_max."""
    insts = _instances(rng, 8)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=5)).fit(insts[2:])
    t_max = int(prim.durations_.max())
    base = insts[0]
    reps = 5  # a stream several times longer than any training instance
    long = base.replace(joints=np.concatenate([base.joints] * reps), valid=np.concatenate([base.valid] * reps),
                        object=np.concatenate([base.object] * reps))
    stream = PrimitiveStream(prim, T0)
    sizes = {}
    for t in range(T0, long.n_frames):
        view = protocol_view(long, t + 1, T0)
        got = stream.keys(view, t, t + 1)
        if t + 1 > t_max:
            assert stream.duration == t_max
            if t % 17 == 0:
                ref = prim.predict_key_joints(view, n_observed=T0, duration=t_max)[t]
                assert np.nanmax(np.abs(got[0] - ref)) < TOL
        sizes[t] = stream.state_size
    assert long.n_frames > 4 * t_max
    later = [sizes[t] for t in sizes if t >= t_max]
    assert min(later) == max(later) == sizes[t_max]


def test_stream_is_deterministic_and_checks_its_calls(rng: np.random.Generator) -> None:
    insts = _instances(rng, 6, gaps=True)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(insts[1:])
    runs = []
    for _ in range(2):
        stream = PrimitiveStream(prim, T0)
        runs.append(np.stack([stream.react_keys(protocol_view(insts[0], t + 1, T0), t, t + 1)
                              for t in range(T0, insts[0].n_frames)]))
    assert np.array_equal(runs[0], runs[1], equal_nan=True)
    stream = PrimitiveStream(prim, T0)
    stream.keys(protocol_view(insts[0], T0 + 5, T0), T0 + 4, T0 + 5)
    with pytest.raises(ModelError, match="views must grow"):
        stream.keys(protocol_view(insts[0], T0 + 3, T0), T0 + 4, T0 + 5)
    with pytest.raises(ModelError, match="stop"):
        stream.keys(protocol_view(insts[0], T0 + 8, T0), T0 + 5, T0 + 6)
    with pytest.raises(ModelError, match="not fitted"):
        PrimitiveStream(InteractionPrimitive(), T0)


class _Recorded:
    """A primitive path (the reactor's stream, or the batch path of 7f68f7b: react_keys on the whole view) that keeps
    what it returned."""

    def __init__(self, inner: object) -> None:
        self.inner, self.keys = inner, []

    def react_keys(self, view: Interaction, start: int, stop: int) -> np.ndarray:
        inner = self.inner
        out = (inner.react_keys(view, start, stop) if isinstance(inner, PrimitiveStream)
               else inner.react_keys(view, start, stop, n_observed=T0))  # type: ignore[attr-defined]
        self.keys.append(out)
        return out


def test_the_full_methods_causal_reactor_streams_the_primitive_with_unchanged_outputs(shake8) -> None:  # noqa: ANN001
    """The default method's reactor reads the primitive from a PrimitiveStream: its primitive key joints equal the batch
    path's of 7f68f7b within 1e-9 m frame by frame (within T_max), and so do its reactions to rounding (the body fit's
    two-bone IK near a straight limb magnifies 1e-15 m differences of its targets to about 1e-9 m)."""
    data = list(shake8)
    cfg = SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1, inner_folds=2)
    m = AffordanceMethod("full", learning=LearningConfig(iterations=1), reaction=cfg).fit(data[:4], rng=np.random.default_rng(0))
    inst, t_max = data[6], int(m.primitive_.durations_.max())
    outs, keys = [], []
    for batch in (False, True):
        reactor = m.start(n_observed=T0, offline=False, rng=np.random.default_rng(1))
        assert isinstance(reactor.primitive, PrimitiveStream)
        reactor.primitive = _Recorded(m.primitive_ if batch else reactor.primitive)
        outs.append(np.stack([reactor.react(protocol_view(inst, t + 1, T0), t, t + 1).joints[0]
                              for t in range(T0, min(inst.n_frames, t_max))]))
        keys.append(np.concatenate(reactor.primitive.keys))
    assert len(outs[0]) > 20
    assert np.nanmax(np.abs(keys[0] - keys[1])) < TOL
    assert np.nanmax(np.abs(outs[0] - outs[1])) < 1e-6
