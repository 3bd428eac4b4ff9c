"""The reactor's per-frame shortcuts (issue 24, real-time speed) against the straightforward computations they replace,
bitwise: ``nan_to_zero`` against ``np.nan_to_num``; the type tables' cached row sets against the densities evaluated
row by row with ``np.where``; the interaction primitive's direct LAPACK calls, cached RBF centres and sliced sums against
scipy's ``cho_factor``/``cho_solve``, ``rbf_basis`` and ``np.ix_``; the cached canonical rotation; the reactor's skipped
body fit (a decision point: skipped only when no member of the blend reads it). And what the reactor's state holds on a
long stream: everything but the canonical track's buffers stays the same size."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
from scipy.linalg import cho_factor, cho_solve

from socialaff_sim.data import Interaction
from socialaff_sim.data.growing import GrowingInteraction
from socialaff_sim.errors import ModelError
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference import methods, primitive_stream, primitive_sums
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig, rbf_basis
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.model.nan_fill import nan_to_value, nan_to_zero
from socialaff_sim.inference.type_tables import TypeTables
from socialaff_sim.model.densities import expon_logpdf, vonmises_logpdf, weibull_logpdf
from socialaff_sim.model.features import polar
from socialaff_sim.model.frame import canonical_frame
from socialaff_sim.model.joints import canonical_joints, instance_frame

from test_primitive_stream import _instances
from test_reactor_stream import _repeat

T0 = 10


def test_nan_to_zero_equals_nan_to_num(rng: np.random.Generator) -> None:
    x = rng.normal(size=(40, 7))
    x[rng.random(x.shape) < 0.2] = np.nan
    x[0, 0] = -0.0
    for special in (None, np.inf, -np.inf):
        y = x.copy()
        if special is not None:
            y[3, 4] = special
        ref = np.nan_to_num(y)
        out = nan_to_zero(y)
        assert np.array_equal(out, ref) and np.array_equal(np.signbit(out), np.signbit(ref))
        assert out is not y and np.isnan(y).any()  # a new array; the input kept
        for fill in (1.0, -2.5):  # the candidates' parameter rows fill NaN with 1
            ref, out = np.nan_to_num(y, nan=fill), nan_to_value(y, fill)
            assert np.array_equal(out, ref) and np.array_equal(np.signbit(out), np.signbit(ref))
            assert (out == fill).sum() == np.isnan(y).sum()  # the fill is used, not 0


def _density_reference(tables: TypeTables, vecs: np.ndarray, params: np.ndarray, expon: np.ndarray) -> np.ndarray:
    """The densities as the tables computed them before the row sets were cached: both kinds, picked by np.where."""
    h, v, th = polar(vecs, tables.eps)
    kh, lh, kv, lv, mu, kap = params.T
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.where(expon, expon_logpdf(h, lh) + expon_logpdf(v, lv), weibull_logpdf(h, kh, lh) + weibull_logpdf(v, kv, lv))
        return dist + vonmises_logpdf(th, mu, kap)


@pytest.mark.parametrize("kind", ["none", "all", "mixed"])
def test_type_table_row_sets_equal_the_densities(shake8_model, rng: np.random.Generator, kind: str) -> None:  # noqa: ANN001
    tables = TypeTables(shake8_model)
    R = 9
    params = np.column_stack([rng.uniform(0.8, 3, R), rng.uniform(0.1, 1, R), rng.uniform(0.8, 3, R), rng.uniform(0.1, 1, R),
                              rng.uniform(-3, 3, R), rng.uniform(0, 20, R)])
    params[1, [0, 2]] = 1.0  # Weibull shape 1: the 0 · log 0 convention
    expon = {"none": np.zeros(R, bool), "all": np.ones(R, bool), "mixed": rng.random(R) < 0.5}[kind]
    expon[0] = kind != "none"
    expon[-1] = kind == "all"
    vecs = rng.normal(scale=0.5, size=(50, R, 3))
    vecs[4, 2] = 0.0  # floored at eps
    vecs[7, 3] = np.nan
    ref = _density_reference(tables, vecs, params, expon)
    for _ in range(2):  # made, then read from the cache
        out = tables._density(vecs, tables._rows(("test", 0), params, expon))
        assert np.array_equal(out, ref, equal_nan=True)
    # The model's own tables, per type and for all types, against the same reference on configurations.
    configs = rng.normal(scale=0.4, size=(30, 11, 3)) + np.array([0.0, 0.0, 1.0])
    for s in [None, *range(tables.S)]:
        rows = slice(None) if s is None else tables.mo_type == s
        dens = _density_reference(tables, configs[:, tables.mo_joint[rows]], tables.mo_params[rows], tables.mo_expon[rows])
        if s is None:  # summed by type, each type's rows on their own (a type with no row: 0)
            ref_m = np.stack([dens[:, tables.mo_type == k].sum(axis=-1) for k in range(tables.S)], axis=-1)
        else:
            ref_m = dens.sum(axis=-1)
        ref_m = np.where(np.isnan(ref_m), -np.inf, ref_m)
        for _ in range(2):
            assert np.array_equal(tables.motion(configs, s), ref_m)


def _stream_outputs(prim: InteractionPrimitive, inst: Interaction) -> np.ndarray:
    stream = PrimitiveStream(prim, T0)
    hidden = observed_part(inst, T0)
    views = GrowingInteraction(hidden)
    out = []
    for t in range(T0, inst.n_frames):
        views.append_from(hidden, t + 1)
        out.append(stream.react_keys(views.view(), t, t + 1))
    return np.concatenate(out)


def test_primitive_stream_shortcuts_equal_scipy_and_rbf_basis(monkeypatch: pytest.MonkeyPatch) -> None:
    """Direct potrf/potrs, cached RBF centres and sliced sums: bitwise the outputs of cho_factor/cho_solve, rbf_basis
    and np.ix_, on instances with tracking gaps, an object and a stream past the longest training duration."""
    insts = _instances(np.random.default_rng(5), 7, gaps=True)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(insts[2:])
    tests = [insts[0], insts[1], _repeat(insts[1], 3)]
    new = [_stream_outputs(prim, inst) for inst in tests]

    def potrf(a: np.ndarray, lower: int, clean: int, overwrite_a: int) -> tuple[np.ndarray, int]:
        return cho_factor(a, lower=True, check_finite=False)[0], 0

    def potrs(c: np.ndarray, b: np.ndarray, lower: int) -> tuple[np.ndarray, int]:
        return cho_solve((c, True), b, check_finite=False), 0

    monkeypatch.setattr(primitive_stream, "dpotrf", potrf)
    monkeypatch.setattr(primitive_stream, "dpotrs", potrs)
    monkeypatch.setattr(PrimitiveStream, "_rbf", lambda self, phase: rbf_basis(phase, self._n, self._width))
    monkeypatch.setattr(primitive_sums, "_block", np.ix_)
    old = [_stream_outputs(prim, inst) for inst in tests]
    for a, b in zip(new, old, strict=True):
        assert np.array_equal(a, b, equal_nan=True)
    assert np.isfinite(new[2]).any()


def test_primitive_stream_block_index() -> None:
    a = np.arange(60.0).reshape(6, 10)
    for rows, cols in [([1, 2, 3], [4, 5]), ([1, 3], [4, 5]), ([2], [0, 2, 3]), ([], [1])]:
        r, c = np.array(rows, np.int64), np.array(cols, np.int64)
        idx = primitive_sums._block(r, c)
        assert isinstance(idx[0], slice) == (len(rows) > 0 and rows == list(range(rows[0], rows[-1] + 1))
                                             and cols == list(range(cols[0], cols[-1] + 1)))
        assert np.array_equal(a[idx], a[np.ix_(r, c)])


def test_canonical_rotation_is_made_once_and_read_only() -> None:
    frame = canonical_frame(np.array([0.2, -0.1, 0.9]), np.array([1.4, 0.8, 0.95]))
    c, s = np.cos(frame.heading), np.sin(frame.heading)
    assert np.array_equal(frame.rotation, np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
    assert frame.rotation is frame.rotation
    with pytest.raises(ValueError):
        frame.rotation[0, 0] = 2.0
    assert copy.deepcopy(frame).rotation is not frame.rotation


def _with_priors(method: AffordanceMethod, plan: bool) -> AffordanceMethod:
    """A copy whose first member reads the plan's skeletons as its prior (``plan``) or whose members read none."""
    m = copy.deepcopy(method)
    members = []
    for k, mem in enumerate(m.reaction_.members_):
        groups = tuple(g for g in mem.groups if g not in ("from_plan", "from_primitive"))
        if plan and k == 0:
            groups = (*groups, "from_plan")
        members.append(dataclasses.replace(mem, groups=groups))
    m.reaction_.members_ = members
    return m


@pytest.mark.parametrize("plan", [False, True])
def test_the_plan_body_fit_is_skipped_only_when_unread(shake8, primitive_method: AffordanceMethod, monkeypatch: pytest.MonkeyPatch,  # noqa: ANN001
                                                        plan: bool) -> None:
    method = _with_priors(primitive_method, plan)
    inst = list(shake8)[5]
    reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
    assert reactor._plan_prior == plan
    new = run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3))
    calls = []
    fit = type(method.body_).fit_poses
    monkeypatch.setattr(type(method.body_), "fit_poses", lambda self, *a: calls.append(1) or fit(self, *a))
    init = methods._AffordanceReactor.__init__

    def always(self, *a) -> None:  # noqa: ANN001
        init(self, *a)
        self._plan_prior = True  # the body fit at every frame, as before

    monkeypatch.setattr(methods._AffordanceReactor, "__init__", always)
    old = run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3))
    assert np.array_equal(new.joints, old.joints, equal_nan=True) and np.array_equal(new.key_joints, old.key_joints, equal_nan=True)
    assert len(calls) == inst.n_frames - T0

    def never(self, *a) -> None:  # noqa: ANN001
        init(self, *a)
        self._plan_prior = False  # the decision inverted

    monkeypatch.setattr(methods._AffordanceReactor, "__init__", never)
    if plan:  # a member reads the skeletons: skipping them cannot go unnoticed
        with pytest.raises(ModelError, match="from_plan"):
            run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3))


def _array_bytes(obj: object, skip: set[int]) -> int:
    """Bytes of the NumPy buffers reachable from ``obj``'s attributes and containers (a view counts its base, once),
    not through ``skip`` (ids) nor into an Interaction (the evaluation's frames)."""
    total, stack, seen = 0, [obj], set(skip)
    while stack:
        x = stack.pop()
        if id(x) in seen or isinstance(x, (str, bytes, int, float, bool, type(None), np.random.Generator, Interaction)):
            continue
        seen.add(id(x))
        if isinstance(x, np.ndarray):
            if isinstance(x.base, np.ndarray):
                stack.append(x.base)
            else:
                total += x.nbytes
        elif isinstance(x, dict):
            stack.extend([*x.keys(), *x.values()])
        elif isinstance(x, (list, tuple, set)):
            stack.extend(x)
        elif hasattr(x, "__dict__"):
            stack.extend(vars(x).values())
    return total


def test_reactor_state_is_flat_on_a_long_stream(shake8, primitive_method: AffordanceMethod) -> None:  # noqa: ANN001
    """On a stream 8× longer than any training instance (about five of the reactor's windows): the primitive's sums,
    the forward belief, the feature window and the canonical track's windows (the synthesizer's
    working track, the stream's world and canonical copies and wrist paths) are the same size late in the stream as
    after its first windows; the windows hold at most twice L + ΔT + 1 frames."""
    inst = observed_part(_repeat(list(shake8)[5], 8), T0)
    views = GrowingInteraction(inst)
    reactor = primitive_method.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
    sizes = {}
    marks = {inst.n_frames // 2, inst.n_frames - 1}
    for t in range(T0, inst.n_frames):
        views.append_from(inst, t + 1)
        reactor.react(views.view(), t, t + 1)
        if t in marks:
            # The planner's per-type caches (reference weights, stacked potentials) fill as types are first planned:
            # bounded by the number of sub-event types, not by the time elapsed.
            syn = reactor.synths[0]
            sizes[t] = _array_bytes(reactor, {id(primitive_method), id(syn._refw), id(syn._tables)})
    a, b = sorted(marks)
    assert a > 2 * syn.window and syn._track.floor > 0
    assert sizes[a] == sizes[b] > 0
    assert len(syn._refw) <= syn.model.n_subevents_
    windows = [syn._track, syn._view._world, syn._view._canon, syn._view._paths]
    assert all(w.capacity <= 2 * (syn.window + syn.config.delta_t + 1) for w in windows)


def test_forward_belief_posterior_read_twice_and_after_a_reset(shake8, shake8_model) -> None:  # noqa: ANN001
    """The posterior kept for a second read at the same frame is the one computed afresh, also after a reset."""
    inst = list(shake8)[6]
    track = canonical_joints(inst, instance_frame(inst))
    fb = ForwardBelief(shake8_model, inst.fps, stride=3, horizon=12)
    t = 40
    fb.advance(track, t)
    first = fb.posterior(t)
    assert all(np.array_equal(a, b) for a, b in zip(first, fb.posterior(t), strict=True))
    fb.reset(21)
    fb.advance(track, t)
    fresh = ForwardBelief(shake8_model, inst.fps, stride=3, horizon=12)
    fresh.reset(21)
    fresh.advance(track, t)
    again, ref = fb.posterior(t), fresh.posterior(t)
    assert all(np.array_equal(a, b) for a, b in zip(again, ref, strict=True))
    assert not all(a.shape == b.shape and np.array_equal(a, b) for a, b in zip(again, first, strict=True))
