"""The fit's speed-ups give bitwise what they replace (issue 24: fit <= 60 s per interaction).

Each shortcut is checked with ``np.array_equal`` against the plain computation it replaces, kept here as the
reference: the key joints filled alone against :meth:`Interaction.filled_joints`; the causal views' key joints and
object (:class:`PrefixViews`) against :func:`protocol_view`; the cached basis rows against :func:`rbf_basis`; and the
interaction primitive's causal predictions of the training rows against the loop that built every view and ran
:meth:`InteractionPrimitive.react_keys` on it, on instances with untracked frames of either agent (frame 0 included)
and with an object.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data import Interaction
from socialaff_sim.data.interaction import fill_key_joints
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ModelError
from socialaff_sim.inference.body_fit import BodyFitter
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, PrefixBasis, ProMPConfig, rbf_basis
from socialaff_sim.inference.methods import primitive_trace
from socialaff_sim.inference.primitive_stream import PrimitiveStream, stream_key_joints
from socialaff_sim.inference.protocol import PrefixViews, observed_part, protocol_view
from socialaff_sim.inference.reaction_regression import key_error
from socialaff_sim.inference.switching_rows import Trace
from socialaff_sim.model.densities import weibull_logpdf

T0 = 10


def _instance(rng: np.random.Generator, k: int, *, gaps: bool, obj: bool) -> Interaction:
    """A reaching instance (agent 1 mirrors agent 0 with its own amplitude); with ``gaps``, untracked runs of
    frames in both agents (agent 0's base at frame 0 among them on every other instance, and one key joint
    of agent 0 untracked to the end)."""
    T = int(rng.integers(26, 40))
    s = np.linspace(0, 1, T)
    body0 = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
    body1 = body0 * [-1, -1, 1] + [1.4, 0.2, 0]
    a0 = np.repeat(body0[None], T, 0) + rng.normal(0, 0.01, size=(T, 5, 3))
    a1 = np.repeat(body1[None], T, 0) + rng.normal(0, 0.01, size=(T, 5, 3))
    bump = np.sin(np.pi * s) * rng.uniform(0.2, 0.5)
    a0[:, 1, 0] += bump
    a1[:, 2, 0] -= bump
    joints = np.stack([a0, a1], 1)
    valid = np.ones((T, 2, 5), bool)
    if gaps:
        for a in range(2):
            for _ in range(3):
                j, f0 = int(rng.integers(0, 5)), int(rng.integers(1, T - 4))
                valid[f0:f0 + int(rng.integers(1, 6)), a, j] = False
        if k % 2 == 0:
            valid[:3, 0, 0] = False  # the canonical frame's base comes from a later frame
        valid[T - 5:, 0, 3] = False  # a gap still open at the end
        valid[2:5, 1, 1] = False  # agent 1 untracked inside its observed prefix
        joints = np.where(valid[..., None], joints, np.nan)
    track = np.c_[np.linspace(0.2, 1.2, T), np.zeros(T), np.full(T, 1.0)] if obj else None
    return Interaction("reach", 10.0, joints, KEY_JOINTS, (f"p{k % 3}", f"q{k % 3}"), object=track, valid=valid,
                       instance_id=f"r{k:02d}")


def test_filled_key_joints_are_the_key_columns_of_filled_joints(rng: np.random.Generator) -> None:
    for k in range(6):
        inst = _instance(rng, k, gaps=True, obj=False)
        full = inst.filled_joints()
        ref = np.stack([full[:, :, i] for i in inst.layout.key_indices], axis=2)
        assert np.array_equal(inst.key_joints(), ref, equal_nan=True)
        assert np.array_equal(fill_key_joints(inst.joints, inst.valid, inst.layout.key_indices), ref, equal_nan=True)
    never = _instance(rng, 1, gaps=True, obj=False)
    valid = never.valid.copy()
    valid[:, 0, 4] = False  # a key joint never tracked stays NaN
    never = never.replace(joints=np.where(valid[..., None], never.joints, np.nan), valid=valid)
    assert np.isnan(never.key_joints()[:, 0, 4]).all()
    assert np.array_equal(never.key_joints()[:, 0, 4], never.filled_joints()[:, 0, 4], equal_nan=True)


@pytest.mark.parametrize("gaps", [False, True])
def test_prefix_views_are_the_protocol_views(rng: np.random.Generator, gaps: bool) -> None:
    for k in range(4):
        inst = _instance(rng, k, gaps=gaps, obj=k % 2 == 1)
        views = PrefixViews(inst, T0)
        for v in range(T0 + 1, inst.n_frames + 1):
            view = protocol_view(inst, v, T0)
            assert np.array_equal(views.key_joints(v), view.key_joints(), equal_nan=True), (k, v)
            ref_obj = view.object
            got_obj = views.object(v)
            assert (got_obj is None) == (ref_obj is None)
            if ref_obj is not None:
                assert np.array_equal(got_obj, ref_obj)


def test_prefix_basis_rows_are_the_basis_computed_for_that_many_frames() -> None:
    basis = PrefixBasis(12, 1.0, 300)
    for span in (1, 7, 29, 60, 299):
        for t in (1, 2, 9, 31, 150, 300):
            assert np.array_equal(basis.rows(span, t), rbf_basis(np.minimum(np.arange(t) / span, 1.0), 12, 1.0))


def _causal_reference(prim: InteractionPrimitive, inst: Interaction, n_observed: int) -> np.ndarray:
    """The loop :meth:`InteractionPrimitive.causal_key_joints` replaced: every causal view built and conditioned on."""
    out = np.full((inst.n_frames, 5, 3), np.nan)
    for t in range(n_observed, inst.n_frames):
        out[t] = prim.react_keys(protocol_view(inst, t + 1, n_observed), t, t + 1, n_observed=n_observed)[0]
    return out


@pytest.mark.parametrize(("gaps", "obj"), [(False, False), (True, False), (True, True)])
def test_causal_key_joints_equal_the_per_view_loop(rng: np.random.Generator, gaps: bool, obj: bool) -> None:
    insts = [_instance(rng, k, gaps=gaps, obj=obj) for k in range(9)]
    prim = InteractionPrimitive().fit(insts[1:])
    for inst in insts[:1] + [_instance(rng, 20, gaps=gaps, obj=obj)]:
        got = prim.causal_key_joints(inst, T0)
        assert np.array_equal(got, _causal_reference(prim, inst, T0), equal_nan=True)
        assert np.isnan(got[:T0]).all() and np.isfinite(got[T0:]).all()
    # Longer than every training instance: the duration estimate runs out of candidates.
    long = _instance(np.random.default_rng(5), 99, gaps=gaps, obj=obj)
    long = long.replace(joints=np.concatenate([long.joints, long.joints]), valid=np.concatenate([long.valid, long.valid]),
                        object=None if long.object is None else np.concatenate([long.object, long.object]))
    assert long.n_frames > prim.durations_.max()
    assert np.array_equal(prim.causal_key_joints(long, T0), _causal_reference(prim, long, T0), equal_nan=True)


def test_training_stream_option_reads_the_stream_and_is_on_by_default(rng: np.random.Generator) -> None:
    """``ProMPConfig.training_stream`` switches the training rows' primitive predictions to the reactor's
    PrimitiveStream: equal to rounding on instances within the training durations, and on by default."""
    assert ProMPConfig().training_stream is True
    insts = [_instance(rng, k, gaps=True, obj=True) for k in range(9)]
    body = BodyFitter().fit_interactions(insts[1:], agent=1, rng=np.random.default_rng(0))
    empty = Trace(belief=np.zeros((1, 1)), phase=np.zeros(1), plan=np.zeros((1, 5, 3)), skeleton=np.zeros((1, 1, 3)))
    probe = insts[0]
    while probe.n_frames > max(i.n_frames for i in insts[1:]):
        probe = _instance(rng, 0, gaps=True, obj=True)
    batch = primitive_trace(InteractionPrimitive(ProMPConfig(training_stream=False)).fit(insts[1:]), body, empty, probe, T0)
    streamed = primitive_trace(InteractionPrimitive(ProMPConfig(training_stream=True)).fit(insts[1:]), body, empty, probe, T0)
    assert np.array_equal(batch.primitive, _causal_reference(InteractionPrimitive().fit(insts[1:]), probe, T0), equal_nan=True)
    assert np.array_equal(streamed.primitive, stream_key_joints(InteractionPrimitive().fit(insts[1:]), probe, T0), equal_nan=True)
    np.testing.assert_allclose(streamed.primitive[T0:], batch.primitive[T0:], atol=1e-9)
    assert not np.array_equal(streamed.primitive, batch.primitive)  # not bitwise: why it is an option


def _stream_reference(prim: InteractionPrimitive, inst: Interaction, n_observed: int) -> np.ndarray:
    """The loop :func:`stream_key_joints` replaced: one stream fed every causal view, built and validated."""
    out = np.full((inst.n_frames, 5, 3), np.nan)
    stream = PrimitiveStream(prim, n_observed)
    for t in range(n_observed, inst.n_frames):
        out[t] = stream.react_keys(protocol_view(inst, t + 1, n_observed), t, t + 1)[0]
    return out


@pytest.mark.parametrize(("gaps", "obj"), [(False, False), (True, False), (True, True)])
def test_stream_key_joints_equal_the_stream_fed_every_view(rng: np.random.Generator, gaps: bool, obj: bool) -> None:
    """The training rows' stream reads each frame from the once-hidden instance (``prefix_keys``) instead of a new
    view a frame: bitwise the same, with agent 0's base first tracked at frame 3 (the stream rebuilds), gaps that
    close, an object, and an instance longer than every training one."""
    insts = [_instance(rng, k, gaps=gaps, obj=obj) for k in range(9)]
    prim = InteractionPrimitive().fit(insts[1:])
    long = _instance(np.random.default_rng(5), 98, gaps=gaps, obj=obj)
    long = long.replace(joints=np.concatenate([long.joints, long.joints]), valid=np.concatenate([long.valid, long.valid]),
                        object=None if long.object is None else np.concatenate([long.object, long.object]))
    assert long.n_frames > prim.durations_.max()
    for inst in [insts[0], _instance(rng, 20, gaps=gaps, obj=obj), long]:
        got = stream_key_joints(prim, inst, T0)
        assert np.array_equal(got, _stream_reference(prim, inst, T0), equal_nan=True)
        assert np.isnan(got[:T0]).all() and np.isfinite(got[T0:]).all()
    short = insts[1].slice(0, T0)  # nothing to predict
    assert np.isnan(stream_key_joints(prim, short, T0)).all()
    stream = PrimitiveStream(prim, T0)
    with pytest.raises(ModelError, match="visible"):
        stream.prefix_keys(observed_part(insts[0], T0), insts[0].n_frames + 1, T0, T0 + 1)


def _weibull_reference(x: np.ndarray, k: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """The Weibull log-density as it was computed before: every term on the broadcast (N, K) arrays."""
    x, k, lam = np.broadcast_arrays(np.asarray(x, float), np.asarray(k, float), np.asarray(lam, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        z = x / lam
        out = np.log(k / lam) - z**k + np.where(k == 1.0, 0.0, (k - 1.0) * np.log(z))
    return np.where(x < 0, -np.inf, out)


def test_weibull_logpdf_on_parameter_rows_is_the_broadcast_computation(rng: np.random.Generator) -> None:
    """The parameters' terms are computed per row (K,) and broadcast: bitwise the (N, K) computation, with x = 0,
    x < 0, NaN and k = 1 among the values, in the layouts the callers use (rows, (B, 1) columns, scalars); and
    scipy's density where it is defined."""
    for _ in range(50):
        n, k_rows = int(rng.integers(1, 200)), int(rng.integers(1, 9))
        x = np.abs(rng.normal(0, 1, (n, k_rows)))
        x[rng.random(x.shape) < 0.05] = 0.0
        x[rng.random(x.shape) < 0.03] = -0.2
        x[rng.random(x.shape) < 0.03] = np.nan
        k = rng.uniform(0.5, 5.0, k_rows)
        k[rng.random(k_rows) < 0.3] = 1.0
        lam = rng.uniform(0.01, 2.0, k_rows)
        for args in ((x, k, lam), (x.T, k[:, None], lam[:, None]), (x[:, 0], float(k[0]), float(lam[0]))):
            got = weibull_logpdf(*args)
            assert np.array_equal(got, _weibull_reference(*args), equal_nan=True)
    xs = np.array([0.05, 0.4, 1.3, 2.5])
    np.testing.assert_allclose(weibull_logpdf(xs, 1.7, 0.8), stats.weibull_min.logpdf(xs, 1.7, scale=0.8), rtol=1e-12)


def test_key_error_by_runs_is_the_mean_over_instances(rng: np.random.Generator) -> None:
    """The rows are averaged by runs of stably sorted ids: bitwise the per-instance mask loop, for rows stacked by
    instance (sorted ids) and for a fold's rows in another order; and a hand-computed two-instance case."""
    def reference(pred: np.ndarray, truth: np.ndarray, ids: np.ndarray) -> float:
        d = np.linalg.norm((pred - truth).reshape(len(pred), -1, 3), axis=-1).mean(axis=1)
        return float(np.mean([d[ids == i].mean() for i in np.unique(ids)]))

    for trial in range(100):
        n = int(rng.integers(1, 300))
        ids = rng.integers(0, 25, n)
        ids = np.sort(ids) if trial % 2 else ids
        pred, truth = rng.normal(size=(n, 15)), rng.normal(size=(n, 15))
        assert key_error(pred, truth, ids) == reference(pred, truth, ids)
    pred = np.zeros((3, 3))
    truth = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
    assert key_error(pred, truth, np.array([0, 1, 1])) == pytest.approx((5.0 + 2.0) / 2)
