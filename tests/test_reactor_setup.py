"""The causal reactor's set-up made once per fitted model instead of once per recording (issue 24, real-time speed: the
recordings' first frames), against what it replaces, bitwise: the type tables against tables made anew, the forward
belief's constants against its former per-recording set-up written out here, the ranks of the types, and the reactor's
outputs on recordings stepped one after another with one model against the same recordings each with its own set-up
(every cached value built per recording). The cache's decision points: a value is made once per model and key, made
anew when a learned attribute is replaced (a refit, a load), and the model's own arrays stay writable. And the first
call's cheaper arithmetic-preserving steps: the primitive's information sums of the first frames against
``np.einsum``, the canonical track, the primitive's frame and the switching regression's anchor each from one gap
filling against the fillings they replace (on layouts with gaps at the first frames), and the primitive's fixed
conditioning parts made before the first frame against those made when first needed."""

from __future__ import annotations

import copy
import gc
import weakref

import numpy as np
import pytest
from scipy.special import log_ndtr

from socialaff_sim.data import Interaction
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference import candidate_planner, forward_belief, model_cache, synthesis, type_tables
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.observed import ObservedInteraction
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.primitive_sums import outer_sums
from socialaff_sim.inference.protocol import protocol_view
from socialaff_sim.inference import primitive_conditioning, primitive_sums
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.reaction_features import Anchor, FeatureConfig, forward_fill, velocity_estimate
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.row_density import RowSet
from socialaff_sim.inference.type_tables import TypeTables
from socialaff_sim.model.frame import canonical_frame
from socialaff_sim.model.joints import canonical_joints, instance_frame
from socialaff_sim.model.nan_fill import nan_to_zero
from socialaff_sim.model.transitions import order_ranks

from test_primitive_stream import _instances
from test_reactor_overhead import _nuitrack_instance

T0 = 10
_USERS = (type_tables, forward_belief, synthesis, candidate_planner)  # the modules that call per_model


def _arrays_equal(a: object, b: object) -> None:
    """``a`` and ``b`` hold bitwise-equal arrays in the same structure (NaN equal to NaN)."""
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes()
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b)  # type: ignore[arg-type]
        for x, y in zip(a, b, strict=True):  # type: ignore[call-overload]
            _arrays_equal(x, y)
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys()
        for k in a:
            _arrays_equal(a[k], b[k])
    elif isinstance(a, (TypeTables, RowSet)):
        assert type(b) is type(a)
        _arrays_equal(vars(a), vars(b))
    else:
        assert a == b or (a != a and b != b)


def test_per_model_once_per_model_and_key_and_anew_after_a_refit(shake8_model) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)  # an object of its own: nothing cached for it yet
    built: list[str] = []

    def build(tag: str):  # noqa: ANN202
        return lambda: built.append(tag) or np.arange(3.0)

    first = model_cache.per_model(model, "k", build("a"))
    assert model_cache.per_model(model, "k", build("b")) is first and built == ["a"]
    other = model_cache.per_model(model, ("k", 2), build("c"))  # another key: its own value
    assert other is not first and built == ["a", "c"]
    assert model_cache.per_model(copy.copy(shake8_model), "k", build("d")) is not first  # another model object
    model.spatial_params_ = model.spatial_params_.copy()  # what fit and load do: a learned attribute replaced
    again = model_cache.per_model(model, "k", build("e"))
    assert again is not first and built[-1] == "e"
    model.config = copy.copy(model.config)  # a configuration replaced, too
    assert model_cache.per_model(model, "k", build("f")) is not again and built[-1] == "f"
    gc.collect()  # the other model copy above is dropped now, not in the count below
    n = len(model_cache._CACHE)
    assert model in model_cache._CACHE
    ref = weakref.ref(model)
    del model
    gc.collect()
    assert ref() is None and len(model_cache._CACHE) == n - 1  # held weakly: dropped with the model


def test_type_tables_of_the_model_are_the_tables_made_anew(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)
    cached = TypeTables.of(model)
    assert TypeTables.of(model) is cached
    fresh = TypeTables(model)  # what every synthesizer and forward belief made before, per recording
    _arrays_equal(vars(cached), vars(fresh))
    assert not cached.sp_params.flags.writeable and not cached._cache[("motion", None)].params.flags.writeable
    end = rng.normal(scale=0.5, size=(40, 11, 3))
    end[3, 2] = np.nan
    for s in (None, *range(model.n_subevents_)):
        np.testing.assert_array_equal(cached.spatial(end, s), fresh.spatial(end, s))
        np.testing.assert_array_equal(cached.motion(end, s), fresh.motion(end, s))
    np.testing.assert_array_equal(cached.duration(np.linspace(0.1, 3, 7)), fresh.duration(np.linspace(0.1, 3, 7)))
    for name in ("spatial_params_", "motion_params_", "duration_params_", "grouping_", "available_"):
        assert getattr(model, name).flags.writeable  # the model's own arrays are not made read-only
    changed = copy.copy(model)
    changed.spatial_params_ = model.spatial_params_ * 1.5  # a refit's new parameters: new tables
    assert not np.array_equal(TypeTables.of(changed).sp_params, cached.sp_params)


def _old_belief_constants(model, fps: float, horizon: int) -> tuple:  # noqa: ANN001
    """ForwardBelief.__init__'s constants as it computed them per recording (commit db864ad), written out."""
    S = model.n_subevents_
    cfg = model.config
    M = 1 << S if cfg.unique_labels else 1
    trans = np.array(model.log_transitions_, dtype=float)
    if cfg.distinct_neighbours and S > 1:
        np.fill_diagonal(trans, -np.inf)
    bits = 1 << np.arange(S)
    masks = np.arange(M)
    src = [masks[(masks & bits[s]) == 0] for s in range(S)] if M > 1 else [masks] * S
    dst = [m | bits[s] for s, m in enumerate(src)] if M > 1 else [masks] * S
    d = np.arange(horizon + 1) / fps
    surv = []
    for s in range(S):
        mu, sigma = model.duration_params_[s]
        secs = np.maximum(d, 1e-9)
        surv.append(log_ndtr(-(np.log(secs) - mu) / sigma) if np.isfinite(mu) and np.isfinite(sigma) else np.full(d.shape, -np.inf))
    sigma = np.asarray(model.path_sigma_, float)
    use = np.isfinite(sigma)
    s2 = np.where(use, sigma, 1.0) ** 2
    return trans, src, dst, bits, np.stack(surv, axis=1), use, np.log(2.0 * np.pi) + np.log(s2), 2.0 * s2


@pytest.mark.parametrize(("fps", "stride", "horizon"), [(30.0, 6, 120), (10.0, 2, 40)])
def test_forward_belief_constants_are_the_per_recording_ones(shake8_model, fps: float, stride: int, horizon: int) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)
    assert model.config.feature_path_profile is not None  # the path constants are made (the default)
    a = ForwardBelief(model, fps, stride=stride, horizon=horizon)
    b = ForwardBelief(model, fps, stride=stride, horizon=horizon)
    assert a._surv is b._surv and a._tables is b._tables is TypeTables.of(model)  # made once, shared
    assert a._sums is not b._sums  # the running sums are the recording's own
    trans, src, dst, bits, surv, use, c, two_s2 = _old_belief_constants(model, fps, a.horizon)
    for got, ref in ((a._trans, trans), (a._bits, bits), (a._surv, surv), (a._path_use, use), (a._path_c, c),
                     (a._path_2s2, two_s2)):
        _arrays_equal(got, ref)
    # The recursion's copy by flat index is F[dst[s], s] = V[src[s], s] of the per-label masks made from the bits.
    S = model.n_subevents_
    _arrays_equal(a._into, np.concatenate([dst[s] * S + s for s in range(S)]))
    _arrays_equal(a._from, np.concatenate([src[s] * S + s for s in range(S)]))
    assert not a._surv.flags.writeable and not a._trans.flags.writeable
    other = ForwardBelief(model, fps, stride=stride, horizon=2 * horizon)  # another horizon: its own survival table
    assert other._surv.shape[0] == other.horizon + 1 != a._surv.shape[0]


def test_order_ranks_once_per_model(shake8_model) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)
    a = OnlineSynthesizer(model, None, SynthesisConfig(ordered=True))
    b = OnlineSynthesizer(model, None, SynthesisConfig(ordered=True))
    assert a._order_ranks() is b._order_ranks()
    np.testing.assert_array_equal(a._order_ranks(), order_ranks(model.parses_, model.n_subevents_))


def test_recordings_one_after_another_are_bitwise_those_set_up_each_alone(shake8, primitive_method: AffordanceMethod,  # noqa: ANN001
                                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Recordings stepped one after another with one fitted model (its set-up made at the first, read by the others)
    against the same recordings each with every cached value built anew (the per-recording set-up): bitwise."""
    method = copy.deepcopy(primitive_method)  # model objects of its own: nothing cached for them yet
    insts = list(shake8)[4:6]  # the second reads the set-up the first made
    assert method.synthesis.ordered and method.synthesis.belief == "forward"  # the reactor's default path
    made: list[object] = []
    per_model = model_cache.per_model

    def counted(model, key, build):  # noqa: ANN001, ANN202
        return per_model(model, key, lambda: made.append(key) or build())

    for mod in _USERS:
        monkeypatch.setattr(mod, "per_model", counted)
    shared = [run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(k))
              for k, inst in enumerate(insts)]
    assert made and len(made) == len(set(made))  # each value once, at the first recording

    def anew(model, key, build):  # noqa: ANN001, ANN202
        made.append(key)
        return build()

    made.clear()
    for mod in _USERS:
        monkeypatch.setattr(mod, "per_model", anew)
    alone = [run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(k))
             for k, inst in enumerate(insts)]
    assert len(made) > len(set(made))  # built again for every recording: the reference did its own set-up
    for a, b in zip(shared, alone, strict=True):
        for name in ("joints", "key_joints", "subevents"):
            assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


@pytest.mark.parametrize("G", [1, 2, 11, 40, 700])
def test_outer_sums_are_einsums_values(rng: np.random.Generator, G: int) -> None:
    """The information of G frames added at once (the stream's first call, and its rebuild after a late-tracked joint)
    per distinct weight column: np.einsum's values, bitwise, with DoFs unseen in some frames (weight 0)."""
    for C, D, N in ((15, 33, 12), (1, 1, 2), (7, 20, 9)):
        phi = np.exp(-10.0 * rng.random((G, C, N)))
        w = np.where(rng.random((G, 1)) < 0.3, 0.0, 1.0) * rng.choice([1 / 0.05**2, 1 / 0.02**2], size=(1, D))
        w = np.where(rng.random((G, D)) < 0.1, 0.0, w)
        got = outer_sums(phi, w)
        assert got.shape == (C, D, N, N)
        assert np.einsum("gcn,gcm,gd->cdnm", phi, phi, w).tobytes() == np.ascontiguousarray(got).tobytes()


def _gappy(rng: np.random.Generator) -> Interaction:
    """The nuitrack10 instance of tests/test_reactor_overhead.py (agent 0's wrist first tracked at frame 18, a gap that
    closes) with agent 1's elbow and base untracked in some of its first frames (the base at frame 0)."""
    inst = _nuitrack_instance(rng, 40)
    valid = np.array(inst.valid, copy=True)
    k = inst.layout.key_indices
    valid[0, 1, k[0]] = False
    valid[3:6, 1, 2] = False
    valid[:4, 1, 5] = False
    joints = np.where(valid[..., None], inst.joints, np.nan)
    return inst.replace(joints=joints, valid=valid)


def test_first_call_fillings_are_the_ones_they_replace(rng: np.random.Generator) -> None:
    inst = _gappy(rng)
    for n in (T0 + 1, 16, 40):
        view = protocol_view(inst, n, T0) if n < inst.n_frames else inst
        longer = view.extend_held(n + 5)
        # The synthesizer's canonical track: one filling for the frame and the joints (was instance_frame's and
        # canonical_joints' own).
        obs = ObservedInteraction.of(longer, T0)
        frame = instance_frame(longer)
        ref = canonical_joints(longer, frame)
        ref[T0:, 5:10] = np.nan
        assert obs.track.tobytes() == ref.tobytes()
        assert obs.frame.rotation.tobytes() == frame.rotation.tobytes() and obs.frame.origin.tobytes() == frame.origin.tobytes()
        np.testing.assert_array_equal(canonical_joints(longer, frame, keys=longer.key_joints()), canonical_joints(longer, frame))
        # The switching regression's anchor: agent 1 filled alone (was the sliced instance's filled_joints).
        cfg = FeatureConfig()
        got = Anchor.from_view(view, T0, cfg)
        filled = view.slice(0, T0).filled_joints()
        valid = np.asarray(view.valid)[:T0]
        keys0 = view.layout.key_joints(forward_fill(view.joints[:T0, 0], valid[:, 0]))
        keys1 = view.layout.key_joints(filled[:, 1])
        b0, b1 = keys0[T0 - 1, 0], keys1[T0 - 1, 0]
        ref_frame = canonical_frame(b0, b1)
        assert np.isfinite(b1).all() and not inst.valid[0, 1, inst.layout.key_indices[0]]  # the gap at frame 0 filled
        assert got.pose.tobytes() == filled[T0 - 1, 1].tobytes() and got.base1.tobytes() == b1.tobytes()
        assert got.keys0.tobytes() == keys0[T0 - 1].tobytes() and got.frame.rotation.tobytes() == ref_frame.rotation.tobytes()
        v = nan_to_zero((velocity_estimate(keys1[-min(cfg.window, T0):]) * view.fps) @ ref_frame.rotation)
        assert got.velocity1.tobytes() == v.tobytes()


def test_primitive_stream_first_call_is_the_einsum_one(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    """The primitive stream over a recording with gaps (agent 0's base untracked at frame 0, a joint first tracked
    after the first call: a rebuild over more frames) with the sums of its first frames by outer_sums against the same
    stream with np.einsum's (the code it replaces): every frame's key joints, the sums and the frame, bitwise."""
    insts = _instances(rng, 6, gaps=True)
    inst = insts[0]
    valid = np.array(inst.valid, copy=True)
    valid[:2, 0, 0] = False
    inst = inst.replace(joints=np.where(valid[..., None], inst.joints, np.nan), valid=valid)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=5)).fit(insts[1:])

    def run() -> tuple[list[np.ndarray], PrimitiveStream]:
        stream = PrimitiveStream(prim, T0)
        return [stream.keys(protocol_view(inst, t + 1, T0), t, t + 1) for t in range(T0, inst.n_frames)], stream

    new, a = run()
    rebuilt: list[int] = []
    monkeypatch.setattr(primitive_sums, "outer_sums", lambda phi, w: rebuilt.append(len(phi)) or np.einsum("gcn,gcm,gd->cdnm", phi, phi, w))
    old, b = run()
    assert rebuilt[0] == T0 + 1 and max(rebuilt) > T0 + 1  # the first call, and a rebuild after the late joint
    for x, y in zip(new, old, strict=True):
        assert x.tobytes() == y.tobytes()
    assert a._hth.tobytes() == b._hth.tobytes() and a._hty.tobytes() == b._hty.tobytes() and a._err.tobytes() == b._err.tobytes()
    frame = instance_frame(protocol_view(inst, inst.n_frames, T0))
    assert a._frame.rotation.tobytes() == frame.rotation.tobytes() and a._frame.origin.tobytes() == frame.origin.tobytes()


def test_warm_fixed_parts_are_the_ones_the_first_recording_made(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    """The primitive's fixed conditioning parts made before the first frame (warm) are the ones the stream looks up:
    with agent 1 tracked in its first T0 frames no frame factors Λ_rr, and the key joints are bitwise those of a cold
    primitive that factors at the frames where it needs them; agent 1 untracked in one of those frames misses and
    makes its own (the same values as cold; a gap between tracked frames is filled, so only a joint never tracked
    before T0 changes B_r); a refitted primitive (a new precision_) does not read the old parts."""
    insts = _instances(rng, 7)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=5)).fit(insts[2:])
    factored: list[int] = []
    cho = primitive_conditioning.cho_factor
    monkeypatch.setattr(primitive_conditioning, "cho_factor", lambda *a, **k: factored.append(1) or cho(*a, **k))

    def run(p: InteractionPrimitive, inst: Interaction, warm: bool) -> list[np.ndarray]:
        stream = PrimitiveStream(p, T0)
        if warm:
            stream.warm()
        return [stream.keys(protocol_view(inst, t + 1, T0), t, t + 1) for t in range(T0, inst.n_frames)]

    gap = insts[1].replace(valid=np.array(insts[1].valid, copy=True))
    valid = np.array(gap.valid, copy=True)
    valid[:T0, 1, 2] = False  # agent 1's wrist never tracked before T0 (a gap is filled): another B_r
    gap = gap.replace(joints=np.where(valid[..., None], gap.joints, np.nan), valid=valid)
    for inst, hits in ((insts[0], True), (gap, False)):
        cold = run(copy.deepcopy(prim), inst, warm=False)
        assert factored  # the cold primitive factors at the frames that need it
        warm_prim = copy.deepcopy(prim)
        PrimitiveStream(warm_prim, T0).warm()
        assert len(factored) >= len(warm_prim.durations_)  # every candidate, before the first frame
        factored.clear()
        got = run(warm_prim, inst, warm=True)
        assert (not factored) == hits  # tracked as usual: no factorisation while stepping; a gap: its own
        for a, b in zip(got, cold, strict=True):
            assert a.tobytes() == b.tobytes()
        factored.clear()
    refit = copy.deepcopy(prim)
    PrimitiveStream(refit, T0).warm()
    refit._precision = refit.precision_ * 2.0  # what a refit does: a new precision_
    factored.clear()
    PrimitiveStream(refit, T0).warm()
    assert len(factored) == len(refit.durations_)  # made anew for the new parameters


def test_add_rows_basis_from_the_table_is_rbf_rows_at_each_phase(rng: np.random.Generator) -> None:
    """The rows added at once read the basis table instead of evaluating rbf_rows at min(s / (T̂ − 1), 1): bitwise
    the evaluated rows, for the first frames, a gap's frames within T_max and frames past T_max (phase 1)."""
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=5)).fit(_instances(rng, 6)[1:])
    st = PrimitiveStream(prim, T0)
    for frames in (np.arange(T0 + 1), np.arange(3, 9), np.arange(st.t_max - 4, st.t_max + 30), np.array([2, 5, 40])):
        for act in (np.arange(len(st._cands)), np.arange(2, len(st._cands))):
            span = np.maximum(st._cands[act] - 1, 1)
            ref = st._rbf(np.minimum(frames[:, None] / span[None], 1.0).ravel()).reshape(len(frames), len(act), st._n)
            assert np.ascontiguousarray(st._table[np.minimum(frames, st.t_max)][:, act]).tobytes() == ref.tobytes()
