"""The causal reactor's per-frame shortcuts of session 24 (issue 24, real-time speed) against what they replace,
bitwise: a stream's canonical joints on a layout that lacks key joints (one gather instead of a copy per joint, the
held joints at once), the tail check by bytes, the track window's plain-slice path, ``nan_to_value``'s copy of a finite
array, one chain's mean, the relabelled working-track columns, the blend's member tables, the candidate draws written
in place, the forward belief's per-frame posterior and the contact keyframe lists."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import LAYOUTS
from socialaff_sim.errors import ModelError
from socialaff_sim.inference.candidates import draw_from, vector_rows
from socialaff_sim.inference.canonical_stream import CanonicalStream
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.methods import chains_mean
from socialaff_sim.inference.protocol import protocol_view
from socialaff_sim.inference.switching import Member, SwitchingConfig, SwitchingRegression
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.track_window import TrackWindow
from socialaff_sim.inference.working_track import OTHERS, _relabelled_others
from socialaff_sim.model.handedness import relabel, wrist_paths
from socialaff_sim.model.joints import canonical_joints, instance_frame
from socialaff_sim.model.nan_fill import nan_to_value, nan_to_zero

T0 = 10


def _nuitrack_instance(rng: np.random.Generator, T: int) -> Interaction:
    """Two agents in the nuitrack10 layout (no ankles: key joints 3 and 4 absent), agent 0 waving, with tracking gaps
    (one closing, one open at the end, one joint first tracked late) and an object."""
    lay = LAYOUTS["nuitrack10"]
    J = len(lay.joint_names)
    base = rng.normal(0, 0.3, (J, 3)) + [0, 0, 1.0]
    a0 = base[None] + np.cumsum(rng.normal(0, 0.01, (T, J, 3)), axis=0)
    a1 = base[None] * [-1, -1, 1] + [1.5, 0, 0] + np.cumsum(rng.normal(0, 0.01, (T, J, 3)), axis=0)
    valid = np.ones((T, 2, J), bool)
    k = lay.key_indices
    valid[15:22, 0, k[1]] = False  # a wrist's gap that closes
    valid[:18, 0, k[2]] = False  # the other wrist first tracked late
    valid[-3:, 0, k[0]] = False  # the base held to the end
    obj = a0[:, k[1]] + [0.05, 0, 0]
    return Interaction("wave", 10.0, np.stack([a0, a1], 1), lay.joint_names, ("p", "q"), object=obj, valid=valid,
                       instance_id="n00")


@pytest.mark.parametrize(("step", "ahead"), [(1, 5), (4, 0)])
def test_canonical_stream_on_a_layout_without_some_key_joints(rng: np.random.Generator, step: int, ahead: int) -> None:
    """The one-gather copy of the key joints and the held joints set at once: the track and paths equal
    canonical_joints / wrist_paths of the lengthened view at every call (bitwise), the absent key joints NaN."""
    inst = _nuitrack_instance(rng, 40)
    assert None in inst.layout.key_indices
    stream = None
    for t in range(T0, inst.n_frames, step):
        view = protocol_view(inst, t + 1, T0)
        longer = view.extend_held(t + 1 + ahead)
        stream = stream or CanonicalStream(instance_frame(longer))
        stream.update(view, longer.n_frames)
        ref = canonical_joints(longer, stream.frame)
        assert np.array_equal(stream.track, ref, equal_nan=True)
        assert np.array_equal(stream.paths, wrist_paths(ref, 0))
    assert np.isnan(np.asarray(stream.track)[:, 3:5]).all()  # the absent ankles
    assert np.isfinite(np.asarray(stream.track)[:, :3]).all()


def test_the_tail_check_compares_values_not_bytes(rng: np.random.Generator) -> None:
    """A view whose last frame seen holds the same values in other bytes (−0 for +0) passes; other values raise."""
    inst = _nuitrack_instance(rng, 30)
    joints = np.array(inst.joints, copy=True)
    joints[12, 0, 0, 0] = 0.0
    inst = inst.replace(joints=joints)
    stream = CanonicalStream(instance_frame(inst))
    stream.update(protocol_view(inst, 13, T0))
    flipped = np.array(joints, copy=True)
    flipped[12, 0, 0, 0] = -0.0
    stream.update(protocol_view(inst.replace(joints=flipped), 14, T0))  # equal values: no error
    moved = np.array(flipped, copy=True)
    moved[13, 0, 0, 0] += 1e-9
    with pytest.raises(ModelError, match="views must grow"):
        stream.update(protocol_view(inst.replace(joints=moved), 15, T0))


def _old_slice(w: TrackWindow, key: slice) -> object:
    """TrackWindow._first's general slice path (the code before the plain-slice shortcut)."""
    if key.step not in (None, 1):
        raise ModelError("step")
    a = 0 if key.start is None else int(key.start)
    b = w.n if key.stop is None else min(int(key.stop), w.n)
    if a < 0 or b < 0:
        raise ModelError("negative")
    if a < w.floor and b > a:
        raise ModelError("before the window")
    a = max(a, w.floor)
    return slice(a - w._base, max(b, a) - w._base)  # noqa: SLF001


def test_track_window_plain_slices_equal_the_general_path() -> None:
    """Every slice a:b (a, b from −2 to n + 2, or None) of windows with several floors: the same rows, or an error
    both ways."""
    w = TrackWindow((2,), capacity=8)
    for floor in (0, 3, 9, 17):
        w.extend(floor + 7)
        w.forget(floor)
        starts = [None, *range(-2, w.n + 3)]
        for a in starts:
            for b in starts:
                key = slice(a, b)
                try:
                    ref = _old_slice(w, key)
                except ModelError:
                    with pytest.raises(ModelError):
                        w._first(key)  # noqa: SLF001
                    continue
                assert w._first(key) == (ref, None)  # noqa: SLF001
    with pytest.raises(ModelError, match="step"):
        w[0:4:2]


def test_nan_to_value_equals_nan_to_num(rng: np.random.Generator) -> None:
    """Values bitwise those of np.nan_to_num (±0 kept, ±inf to ±the largest float), a new array, in np.where's layout,
    whatever the input's layout; an array with a NaN takes the replacing path (the copy would keep it)."""
    x = rng.normal(size=(6, 5, 3))
    x[0, 0, 0] = -0.0
    nan = x.copy()
    nan[1, 2, 0] = np.nan
    inf = nan.copy()
    inf[2, 1, 1] = -np.inf
    for a in (x, nan, inf):
        for view in (a, a.T, a[:, 1:3], a[::2], a[..., 0], np.broadcast_to(a[0], (4, 5, 3)), a.reshape(-1)[:0]):
            for value in (0.0, 1.0):
                out = nan_to_value(view, value)
                assert out.tobytes() == np.nan_to_num(view, nan=value).tobytes()
                assert out.strides == np.where(np.isnan(view), value, view).strides
                assert not np.shares_memory(out, view)
    assert nan_to_zero(nan)[1, 2, 0] == 0.0
    assert np.signbit(nan_to_zero(x)[0, 0, 0])


def test_one_chain_mean_is_np_mean() -> None:
    """One chain: np.mean's values bitwise (−0 made +0 by its sum from 0, NaN and inf kept); two chains: the mean."""
    rng = np.random.default_rng(3)
    x = rng.normal(size=(4, 5, 3))
    x[0, 0, 0], x[1, 1, 1], x[2, 2, 2] = -0.0, np.nan, np.inf
    steps = [[SimpleNamespace(key_joints=row) for row in x]]
    one = chains_mean(steps)  # type: ignore[arg-type]
    assert one.tobytes() == np.mean(x[None], axis=0).tobytes()
    assert not np.signbit(one[0, 0, 0]) and one.tobytes() != x.tobytes()  # the +0 that np.mean makes
    two = [steps[0], [SimpleNamespace(key_joints=row + 1.0) for row in x]]
    assert np.array_equal(chains_mean(two), np.mean(np.stack([x, x + 1.0]), axis=0), equal_nan=True)  # type: ignore[arg-type]


def test_relabelled_others_equal_relabel_then_select(rng: np.random.Generator) -> None:
    x = rng.normal(size=(7, 11, 3))
    cols = set()
    for flags in ((False, False), (True, False), (False, True), (True, True)):
        h = np.array(flags)
        assert np.array_equal(x[:, _relabelled_others(h)], relabel(x, h)[:, OTHERS])
        cols.add(tuple(_relabelled_others(h)))
    assert len(cols) == 2  # agent 0's flag swaps its wrists (and ankles); agent 1's joints are not among them


def _old_displacement(reg: SwitchingRegression, rows: np.ndarray, offset: np.ndarray | None) -> np.ndarray:
    """SwitchingRegression.displacement as it was (per call selections, np.clip)."""
    priors = {"from_plan": offset, "from_primitive": None}
    out = np.zeros((len(rows), reg.n_outputs_))
    for m in reg.members_:
        given = priors[m.prior] if m.prior else None
        part = np.array(given, dtype=np.float64) if given is not None else np.zeros_like(out)
        if len(m.columns):
            x = rows[:, m.columns] / reg.scale_[m.columns]
            if reg.config.clip_features:
                x = np.clip(x, reg.lower_[m.columns], reg.upper_[m.columns])
            part += x @ m.coefficients
        out += m.weight * part
    return out


def test_switching_member_tables_equal_the_per_call_selections(rng: np.random.Generator) -> None:
    """Members with and without a prior, rows beyond the clip bounds: bitwise the old displacement; a refit (a new
    member list) makes the tables anew."""
    reg = SwitchingRegression(SwitchingConfig())
    F, D = 40, 12
    reg.scale_ = rng.uniform(0.5, 2.0, F)
    reg.lower_, reg.upper_ = -rng.uniform(0.5, 1.0, F), rng.uniform(0.5, 1.0, F)
    reg.n_outputs_ = D
    reg.members_ = [Member("a", ("motion", "from_plan"), 1.0, 0.6, np.arange(0, 40, 3), rng.normal(size=(14, D))),
                    Member("b", ("motion",), 1.0, 0.4, np.arange(5, 25), rng.normal(size=(20, D)))]
    rows, offset = rng.normal(0, 2.0, (3, F)), rng.normal(size=(3, D))
    assert np.array_equal(reg.displacement(rows, offset), _old_displacement(reg, rows, offset))
    clipped = _old_displacement(reg, rows, offset)
    reg.members_ = [Member("c", ("motion",), 1.0, 1.0, np.arange(10, 30), rng.normal(size=(20, D)))]
    assert np.array_equal(reg.displacement(rows, None), _old_displacement(reg, rows, None))
    assert not np.array_equal(reg.displacement(rows, None), clipped)
    with pytest.raises(ModelError, match="pass its offset"):
        reg.members_ = [Member("a", ("from_plan",), 1.0, 1.0, np.arange(3), rng.normal(size=(3, D)))]
        reg.displacement(rows, None)


def test_draws_written_in_place_equal_np_stack() -> None:
    params = np.array([[1.5, 0.3, 2.0, 0.1, 0.4, 3.0], [1.0, 0.2, np.nan, 0.2, -1.0, 0.0], [2.5, 0.5, 1.2, 0.3, 2.0, 8.0]])
    rows, up = vector_rows(params), np.array([0.2, 0.5, 0.9])
    for n in (0, 1, 50):
        a, b = np.random.default_rng(7), np.random.default_rng(7)
        new = draw_from(rows, up, n, a)
        kh, lh, kv, lv, mu, kap = rows
        h = lh * b.weibull(kh, size=(n, 3)) if n else None
        if n:
            v = lv * b.weibull(kv, size=(n, 3))
            sign = np.where(b.random((n, 3)) < up, 1.0, -1.0)
            th = b.vonmises(mu, kap, size=(n, 3))
            assert new.tobytes() == np.stack([h * np.cos(th), h * np.sin(th), sign * v], axis=-1).tobytes()
        assert new.shape == (n, 3, 3)


def _old_posterior(fb: ForwardBelief, t: int) -> tuple[np.ndarray, np.ndarray]:
    """ForwardBelief._posterior_at as it was (np.append, np.max, ndarray.sum)."""
    starts = fb._starts  # noqa: SLF001
    d = np.minimum(t - starts, fb.horizon)
    logp = fb._G + fb._surv[d]  # noqa: SLF001
    if fb._has_long:  # noqa: SLF001
        starts = np.append(starts, t - fb.horizon)
        logp = np.concatenate([logp, fb._long_read[None]])  # noqa: SLF001
    top = np.max(logp) if logp.size else -np.inf
    if not np.isfinite(top):
        return np.array([fb.origin], np.int64), np.full((1, fb.S), 1.0 / fb.S)
    p = np.exp(logp - top)
    return starts, p / p.sum()


def test_forward_belief_posterior_equals_the_old_reads(shake8, shake8_model) -> None:  # noqa: ANN001
    """Every frame of a stream three recordings long (the long bucket in use): the starts and the posterior bitwise,
    and the belief the posterior's column sums."""
    insts = list(shake8)[6:8]
    x = np.concatenate([canonical_joints(i, instance_frame(i)) for i in insts + insts[:1]])
    fb = ForwardBelief(shake8_model, insts[0].fps, stride=3, horizon=24)
    longs = 0
    for t in range(1, x.shape[0]):
        fb.advance(x, t)
        ref_starts, ref_p = _old_posterior(fb, t)
        starts, p = fb.posterior(t)
        assert starts.dtype == ref_starts.dtype and np.array_equal(starts, ref_starts)
        assert p.tobytes() == ref_p.tobytes()
        assert fb.belief(t).tobytes() == ref_p.sum(axis=0).tobytes()
        longs += fb._has_long  # noqa: SLF001
    assert longs > 10


def test_contact_keyframe_lists_made_once(shake8, shake8_model) -> None:  # noqa: ANN001
    """The cached lists are the model's keyframes (of every type, and of each), made at the first call; another model
    makes its own."""
    syn = OnlineSynthesizer(shake8_model, None, SynthesisConfig.reactive())
    keys = shake8_model.contact_keys_
    every = syn._keyframes(None)  # noqa: SLF001
    assert [k.joint for k in every] == [k.joint for k in keys.all()] and len(every) == len(keys.all())
    for s in range(shake8_model.n_subevents_):
        assert [(k.joint, k.mate, k.phase) for k in syn._keyframes(s)] == [(k.joint, k.mate, k.phase) for k in keys.of_type(s)]  # noqa: SLF001
    assert syn._keyframes(None) is every  # noqa: SLF001
    other = SimpleNamespace(contact_keys_=keys.empty(shake8_model.n_subevents_), n_subevents_=shake8_model.n_subevents_)
    syn.model = other  # type: ignore[assignment]
    assert syn._keyframes(None) == []  # noqa: SLF001


def test_logsumexp_by_the_ufunc_reductions_equals_np_max_and_np_sum(rng: np.random.Generator) -> None:
    """The forward belief's log-sum-exp (every cut, under the cut's one ``np.errstate``) against the same formula with
    np.max and np.sum, bitwise, with rows and columns all −inf (−inf out, no warning) and mixed ones."""
    from socialaff_sim.inference.forward_belief import _lse

    x = rng.normal(scale=20.0, size=(7, 4, 5))
    x[0] = -np.inf
    x[:, 1, 2] = -np.inf
    x[3, 2] = [-np.inf, 1.0, -np.inf, -np.inf, 2.0]
    for axis in (0, 1, 2):
        top = np.max(x, axis=axis, keepdims=True)
        safe = np.where(np.isfinite(top), top, 0.0)
        with np.errstate(divide="ignore"):
            ref = np.log(np.sum(np.exp(x - safe), axis=axis)) + np.squeeze(safe, axis=axis)
            assert _lse(x, axis).tobytes() == ref.tobytes()
    with np.errstate(divide="ignore"):
        assert np.isneginf(_lse(x, 1)[0]).all()


def test_weibull_terms_kept_give_the_same_log_density(rng: np.random.Generator) -> None:
    """weibull_logpdf with its parameter terms given (the tables' rows) against computing them, bitwise: shape 1 at
    x = 0 (the 0 · log 0 convention), x < 0, x = 0 with shape < 1 (+inf) and NaN."""
    from socialaff_sim.model.densities import weibull_logpdf, weibull_terms

    R = 8
    params = np.column_stack([rng.uniform(0.5, 3, R), rng.uniform(0.1, 1, R)])
    params[1, 0], params[2, 0] = 1.0, 0.7
    k, lam = params.T
    x = rng.uniform(-0.1, 2.0, (40, R))
    x[:, 1:3] = 0.0
    x[5, 4] = np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        new = weibull_logpdf(x, k, lam, terms=weibull_terms(k, lam))
    assert new.tobytes() == weibull_logpdf(x, k, lam).tobytes()
    assert np.isfinite(new[:, 1]).all() and np.isposinf(new[:, 2]).all() and np.isneginf(new[x < 0]).all()
