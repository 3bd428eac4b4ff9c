"""The causal reactor's per-frame cuts of session 26 (issue 24, real-time speed), each against the code it replaces,
written out here, bitwise: the primitive's a-block S + B_a assembled by a contiguous copy and a strided view of its
diagonal blocks (against the transposing copy and the fancy-indexed add), a stream copied mid-way (deepcopy) included;
the primitive's per-frame sums with what depends on the seen DoFs made once per pattern (against the per-frame
selections), within and past T_max, with gaps, a key joint first tracked late and the nuitrack10 layout's missing
ankles; the canonical stream's held frames converted once and broadcast (against converting every copy); the track
window's fast slice reads and writes (against the general indexing, errors included); and the blend's rows with only
the groups its members read (against every group computed), on the reactor's whole path."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from socialaff_sim.errors import ModelError
from socialaff_sim.inference import methods, primitive_sums
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.primitive_sums import diagonal_blocks
from socialaff_sim.inference.protocol import observed_part, protocol_view
from socialaff_sim.inference.reaction_features import FEATURE_GROUPS
from socialaff_sim.inference.switching_rows import switching_columns, switching_rows
from socialaff_sim.inference.canonical_stream import _WRISTS, CanonicalStream, _key_columns
from socialaff_sim.inference.primitive_sums import OUTER_SUMS_KEPT, outer_sums
from socialaff_sim.inference.track_window import TrackWindow
from socialaff_sim.model.joints import N_JOINTS, OBJECT, instance_frame
from socialaff_sim.model.frame import CanonicalFrame

from test_primitive_stream import _instances
from test_reactor_overhead import _nuitrack_instance

T0 = 10


# ----------------------------------------------------------------------------- the code replaced, written out
class _OldABlock(PrimitiveStream):
    """The a-block as it was assembled: a transposing copy of S into the Fortran-ordered buffer, the diagonal blocks
    added through a fancy-indexed view of a reshape."""

    def _a_block(self, s_aa: np.ndarray, blocks: np.ndarray) -> np.ndarray:
        lam = self._lam
        np.copyto(lam, s_aa)
        m, n = self._d0, self._n
        lam.reshape((n, m, n, m), order="F")[:, np.arange(m), :, np.arange(m)] += blocks
        return lam


class _OldSums(_OldABlock):
    """The per-frame sums as they were: the seen DoFs' weights, their equality and the agent-0 columns selected at
    every frame."""

    def _add_frame(self, s: int, y: np.ndarray) -> None:
        from socialaff_sim.inference.primitive_sums import _runs

        seen = np.isfinite(y)
        if s >= self.n_observed:
            seen[self._d0 :] = False
        n_c = len(self._cands)
        lo = min(int(self._cands.searchsorted(s, side="right")), n_c - 1)
        cols = seen.nonzero()[0]
        p0 = self._table[min(s, self.t_max), lo:]
        yz = y[cols] * self._inv_var[cols]
        w = self._inv_var[cols]
        outer = p0[:, :, None] * p0[:, None, :]
        equal = bool(w.size) and bool((w == w[0]).all())
        hth = (outer * w[0])[:, None] if equal else outer[:, None] * w[None, :, None, None]
        key = ("old", cols.tobytes())
        runs = self._col_runs.get(key)
        if runs is None:
            runs = self._col_runs[key] = _runs(cols)
        for a, b, ka, kb in runs:
            self._hty[lo:, a:b] += p0[:, None, :] * yz[None, ka:kb, None]
            self._hth[lo:, a:b] += hth if equal else hth[:, ka:kb]
        if self._phase_one is not None:
            a_cols = cols < self._d0
            self._phase_one.weights[cols[a_cols]] += w[a_cols]
            self._phase_one_frames += 1
        if s >= self.t_max:
            return
        obs = y[: self._d0] - self._first
        mu = p0 @ self._mean[: self._d0].T - self._mu0
        diff = obs[None] - mu
        if not np.isfinite(obs).all():
            diff = np.where(np.isfinite(obs)[None], diff, 0.0)
        self._err[lo:] += (diff**2).sum(axis=1)


class _OldCanonical(CanonicalStream):
    """The canonical stream's frames consumed as they were: every call by the masks over the new frames (the one-frame
    call included)."""

    def _consume(self, view, start: int, stop: int) -> int:  # noqa: ANN001
        dst, agent, src = _key_columns(view.layout.key_indices)
        x = np.full((stop - start, N_JOINTS, 3), np.nan)
        ok = np.zeros((stop - start, N_JOINTS), dtype=bool)
        valid = np.asarray(view.valid)
        if dst.size:
            x[:, dst] = view.joints[start:stop][:, agent, src]
            ok[:, dst] = valid[start:stop][:, agent, src]
        if view.object is not None:
            x[:, OBJECT] = view.object[start:stop]
            ok[:, OBJECT] = True
        world = self._world
        floor = world.floor
        simple = ok.all(axis=0) & (self._last == start - 1)
        world[start:stop, simple] = x[:, simple]
        self._last[simple] = stop - 1
        self._last_pos[simple] = world[stop - 1, simple]
        first = start
        rest = ~simple
        held = rest & ~ok.any(axis=0)
        if held.any():
            world[start:stop, held] = self._last_pos[held]
        for j in (rest & ~held).nonzero()[0]:
            tracked = ok[:, j].nonzero()[0]
            last = int(self._last[j])
            lo = last + 1 if last >= 0 else 0
            xp = np.r_[[last] if last >= 0 else [], start + tracked].astype(np.float64)
            fp = np.concatenate([self._last_pos[j][None] if last >= 0 else np.zeros((0, 3)), x[tracked, j]])
            a = max(lo, floor)
            at = np.arange(a, stop)
            for d in range(3):
                world[a:stop, j, d] = np.interp(at, xp, fp[:, d])
            for p in world.pinned:
                if lo <= p < floor:
                    for d in range(3):
                        world[p, j, d] = np.interp(float(p), xp, fp[:, d])
            if j in _WRISTS and lo <= floor and floor > 0:
                self._carry[j] = (last, xp, fp)
            self._last[j] = start + int(tracked[-1])
            self._last_pos[j] = world[int(self._last[j]), j]
            first = min(first, lo)
        return first


def _held_frames_old(frame: CanonicalFrame, last_pos: np.ndarray, k: int) -> np.ndarray:
    """The canonical stream's held frames as they were: every copy converted."""
    return frame.to_canonical(np.broadcast_to(last_pos, (k, last_pos.shape[0], 3)))


def _getitem_old(w: TrackWindow, key: object) -> np.ndarray:
    """TrackWindow's indexing as it was (every key through ``_first``)."""
    first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
    k, row = w._first(first)
    if k is None:
        return row[rest] if rest else row  # type: ignore[index]
    return w._buf[(k,) + rest]


# ----------------------------------------------------------------------------------------------------- tests
def _bytes_equal(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape and a.dtype == b.dtype
    assert a.tobytes() == b.tobytes()


def test_diagonal_blocks_view_against_the_fancy_index(rng: np.random.Generator) -> None:
    """The strided view reads and writes the entries the reshape's fancy index does, and S + B_a by a copy of Sᵀ
    equals the transposing copy of S for an exactly symmetric S (0.5 (S + Sᵀ)), bitwise; a non-Fortran buffer is an
    error."""
    for m, n in [(1, 1), (3, 4), (18, 12), (15, 6)]:
        a = m * n
        s = rng.normal(size=(a, a))
        s = 0.5 * (s + s.T)
        blocks = rng.normal(size=(m, n, n))
        old = np.empty((a, a), order="F")
        np.copyto(old, s)
        old.reshape((n, m, n, m), order="F")[:, np.arange(m), :, np.arange(m)] += blocks
        new = np.empty((a, a), order="F")
        np.copyto(new, s.T)
        view = diagonal_blocks(new, m, n)
        assert view.base is new
        view += blocks
        _bytes_equal(np.asfortranarray(old), np.asfortranarray(new))
        for i in range(m):  # the view's entry [i, p, q] is lam[i n + p, i n + q]
            _bytes_equal(view[i], new[i * n : (i + 1) * n, i * n : (i + 1) * n])
    s = rng.normal(size=(6, 6))
    asym = np.empty((6, 6), order="F")
    np.copyto(asym, s.T)
    assert not np.array_equal(asym, s)  # the copy of Sᵀ relies on S's symmetry: it is S only when S is symmetric
    with pytest.raises(ModelError, match="Fortran"):
        diagonal_blocks(np.zeros((6, 6)), 2, 3)


def _fitted(rng: np.random.Generator, layout: str) -> tuple[InteractionPrimitive, list]:
    if layout == "nuitrack10":
        insts = [_nuitrack_instance(rng, int(rng.integers(34, 44))) for _ in range(5)]
        insts = [dataclasses.replace(i, instance_id=f"n{k:02d}") for k, i in enumerate(insts)]
    else:
        insts = _instances(rng, 5, gaps=True)
    return InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(insts[2:]), insts[:2]


@pytest.mark.parametrize("layout", ["default", "nuitrack10"])
def test_primitive_stream_frames_against_the_replaced_code(rng: np.random.Generator, layout: str) -> None:
    """A stream with the new a-block and sums against one with the old code (both written out above): the key joints
    of every frame and every running sum bitwise equal, within T_max and past it (the instance lengthened by held
    frames: the low-rank path and its weights), on instances with gaps that close, a joint first tracked late, an
    open gap at the end and, on nuitrack10, key joints absent from the layout; and a stream copied mid-way (deepcopy:
    its view of the buffer is a detached copy, which it must not write into) equal to both."""
    prim, tests = _fitted(rng, layout)
    for inst in tests:
        long = inst.extend_held(prim.durations_.max() + 25)  # past T_max
        hidden = observed_part(long, T0)
        new, old = PrimitiveStream(prim, T0), _OldSums(prim, T0)
        fork = None
        deferred = 0
        for t in range(T0, long.n_frames):
            a = new.react_prefix_keys(hidden, t + 1, t, t + 1)
            b = old.react_prefix_keys(hidden, t + 1, t, t + 1)
            _bytes_equal(a, b)
            if fork is not None:
                _bytes_equal(fork.react_prefix_keys(hidden, t + 1, t, t + 1), a)
            if t == T0 + 8:
                fork = copy.deepcopy(new)
                assert fork._lam_blocks.base is not fork._lam  # the copy's view is apart: it is made anew
            # Every candidate still to be chosen, its deferred frames added (on a copy: the stream's own flushes
            # stay as they come), has the sums of the frames added as they came; _err is never deferred.
            flushed = copy.deepcopy(new)
            deferred += len(flushed._log) > 0
            flushed._flush_active()
            lo = flushed._active
            for name in ("_hth", "_hty"):
                _bytes_equal(getattr(flushed, name)[lo:], getattr(old, name)[lo:])
            _bytes_equal(new._err, old._err)
        assert deferred > 0  # frames were deferred within T_max
        assert not new._log  # past T_max: T_max alone, nothing deferred
        lo = new._active
        for name in ("_hth", "_hty"):
            _bytes_equal(getattr(new, name)[lo:], getattr(old, name)[lo:])
        assert new._phase_one is not None and old._phase_one is not None
        _bytes_equal(new._phase_one.weights, old._phase_one.weights)
        assert fork._lam_blocks.base is fork._lam


def test_primitive_sums_equal_weights_decision(rng: np.random.Generator) -> None:
    """The pattern's equal-weight decision: agent 1's DoFs (seen before T0) carry another weight than agent 0's, so
    the broadcast product with one weight must not be taken for a pattern holding both (it would give other sums);
    the per-frame calls (after T0) see agent 0's DoFs only, one weight, and take it."""
    prim, tests = _fitted(rng, "default")
    stream = PrimitiveStream(prim, T0)
    for t in range(T0, T0 + 6):
        stream.keys(protocol_view(tests[0], t + 1, T0), t, t + 1)
    patterns = list(stream._col_runs.values())
    assert patterns and all(p.w0 is not None for p in patterns)
    seen = type(patterns[0])
    cols = np.arange(stream._n_dof)
    mixed = seen(cols, stream._inv_var, stream._d0)
    assert mixed.w0 is None and len(np.unique(mixed.w)) == 2
    _bytes_equal(mixed.cols_a, cols[: stream._d0])
    p0 = stream._table[3, :]
    outer = p0[:, :, None] * p0[:, None, :]
    per_dof = outer[:, None] * mixed.w[None, :, None, None]
    inverted = np.broadcast_to((outer * mixed.w[0])[:, None], per_dof.shape)
    assert not np.array_equal(per_dof, inverted)
    agent0 = seen(cols[: stream._d0], stream._inv_var, stream._d0)
    assert agent0.w0 == stream._inv_var[0]
    _bytes_equal(np.broadcast_to((outer * agent0.w0)[:, None], (len(p0), stream._d0) + outer.shape[1:]),
                 outer[:, None] * agent0.w[None, :, None, None])


def test_canonical_held_frames_converted_once(rng: np.random.Generator) -> None:
    """The held frames' canonical values, one frame converted and broadcast, against every copy converted: bitwise,
    NaN joints (never tracked) included, for 1–40 held frames and random frames."""
    for _ in range(300):
        frame = CanonicalFrame(origin=np.r_[rng.normal(size=2) * 3, 0.0], heading=float(rng.uniform(-np.pi, np.pi)))
        last = rng.normal(size=(11, 3)) * rng.uniform(0.1, 50)
        last[rng.random(11) < 0.3] = np.nan
        k = int(rng.integers(1, 41))
        dst = np.empty((k, 11, 3))
        dst[:] = frame.to_canonical(last[None])  # what CanonicalStream.update writes now
        _bytes_equal(dst, _held_frames_old(frame, last, k))


def test_track_window_fast_reads_against_the_general_indexing(rng: np.random.Generator) -> None:
    """Slices of held frames given as ints (alone or first in a tuple) read and write the buffer rows the general
    indexing does; every other key (NumPy ints, open ends, past the end, reversed, below the floor, a step, an int,
    an array) goes the general way, with its values or its error."""
    w = TrackWindow((4, 3), name="t")
    w.extend(300)
    w._buf[:] = rng.normal(size=w._buf.shape)
    w.pin(30)
    w.forget(100)
    w.extend(500)  # compacts or grows: base > 0
    keys = [slice(120, 130), (slice(120, 130), slice(1, 3)), (slice(200, 200), 2), slice(np.int64(120), 130),
            slice(120, None), slice(480, 600), slice(140, 120), (slice(100, 101), 0, 1), slice(499, 500), 120,
            np.arange(100, 110), (150, 2)]
    for key in keys:
        _bytes_equal(np.asarray(w[key]), np.asarray(_getitem_old(w, key)))
    for bad in [slice(None, 150), slice(90, 110), (slice(10, 20), 1), slice(100, 120, 2), slice(-5, 3)]:
        with pytest.raises(ModelError):
            w[bad]
        with pytest.raises(ModelError):
            _getitem_old(w, bad)
    _bytes_equal(w[30], _getitem_old(w, 30))  # a pinned frame below the floor, by an int
    v = rng.normal(size=(5, 2, 3))
    w[(slice(200, 205), slice(1, 3))] = v
    _bytes_equal(w._buf[200 - w._base : 205 - w._base, 1:3], v)
    with pytest.raises(ModelError):
        w[(slice(95, 105), slice(1, 3))] = v


def test_switching_rows_groups_read_against_every_group(rng: np.random.Generator) -> None:
    """Rows with only the groups read: each group's columns equal those of the rows with every group (bitwise);
    the groups not computed are zeros (so a member reading a group that was not passed would read zeros: the
    decision matters)."""
    S, N = 4, 3
    motion = rng.normal(size=(N, 49))
    belief = rng.dirichlet(np.ones(S), size=N)
    phase = np.where(rng.random(N) < 0.3, np.nan, rng.random(N))
    plan, prim = rng.normal(size=(N, 15)), rng.normal(size=(N, 15))
    full = switching_rows(motion, belief, phase, plan, prim)
    for groups in [("agent0_velocity", "plan"), ("gap", "agent0_velocity", "primitive"), ("subevent",), ("phase", "gap"),
                   ("agent0", "gated"), ("own_velocity", "gated", "subevent", "phase")]:
        part = switching_rows(motion, belief, phase, plan, prim, groups)
        cols = switching_columns(groups, S)
        _bytes_equal(part[:, cols], full[:, cols])
    part = switching_rows(motion, belief, phase, plan, prim, ("plan",))
    gated = switching_columns(("gated", "agent0"), S)[15:]
    assert not part[:, gated].any() and full[:, gated].any()


def test_reactor_blend_groups_against_every_group(primitive_method, shake8) -> None:  # noqa: ANN001
    """The reactor computing only its blend's groups against the same reactor computing every group (the rows as
    they were): every frame's skeleton bitwise equal on two recordings."""
    groups = primitive_method.reaction_.groups_
    assert set(groups) < set(FEATURE_GROUPS) | {"subevent", "phase", "gated", "plan", "primitive", "from_plan",
                                                 "from_primitive"}
    every = FEATURE_GROUPS + ("subevent", "phase", "gated", "plan", "primitive")
    for inst in list(shake8)[4:6]:
        hidden = observed_part(inst, T0)
        a = primitive_method.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
        b = primitive_method.start(n_observed=T0, offline=False, rng=np.random.default_rng(3))
        assert isinstance(b, methods._AffordanceReactor)
        b._groups = every
        for t in range(T0, inst.n_frames):
            view = protocol_view(inst, t + 1, T0)
            pa, pb = a.react(view, t, t + 1), b.react(view, t, t + 1)
            _bytes_equal(pa.joints, pb.joints)
            _bytes_equal(pa.key_joints, pb.key_joints)
        assert hidden.n_frames == inst.n_frames


@pytest.mark.parametrize(("layout", "keep"), [("default", None), ("nuitrack10", None), ("default", 6), ("nuitrack10", 4)])
def test_canonical_stream_one_frame_call_against_the_masks(rng: np.random.Generator, layout: str, keep: int | None) -> None:
    """The one-new-frame call (the row by one selection) against the masks over the new frames (written out above):
    the track, the paths, each joint's last tracked frame and position bitwise equal at every call, on instances with
    gaps that close, a joint first tracked late, an open gap at the end, the nuitrack10 layout's absent key joints,
    held frames past the view, and a bounded window (``keep_from``) with the pinned hold frame; a call with several
    new frames (the general way) in between."""
    insts = [_nuitrack_instance(rng, 45)] if layout == "nuitrack10" else _instances(rng, 2, gaps=True)
    for inst in insts:
        new = old = None
        t = T0
        while t < inst.n_frames:
            view = protocol_view(inst, t + 1, T0)
            if new is None:
                frame = instance_frame(view)
                new, old = CanonicalStream(frame), _OldCanonical(frame)
                for s in (new, old):
                    s.pin(T0 - 1)
            floor = 0 if keep is None else max(t - keep, 0)
            ca = new.update(view, t + 1 + 5, keep_from=floor)
            cb = old.update(view, t + 1 + 5, keep_from=floor)
            assert ca == cb
            lo = new.floor
            _bytes_equal(new.track[lo : new.n_frames], old.track[lo : old.n_frames])
            _bytes_equal(new.paths[lo : new.n_frames], old.paths[lo : old.n_frames])
            _bytes_equal(new.track[T0 - 1], old.track[T0 - 1])
            _bytes_equal(new._last, old._last)
            _bytes_equal(new._last_pos, old._last_pos)
            t += 3 if t % 7 == 0 else 1  # now and then several new frames at once


def test_outer_sums_kept_by_their_inputs(rng: np.random.Generator) -> None:
    """A kept result is the one computed anew (bitwise), read-only; other inputs (one weight changed, or the basis)
    are not served it; results of more than 64 frames are computed and not kept; the oldest is dropped first."""
    primitive_sums._OUTER.clear()
    phi = rng.random((11, 5, 4))
    w = np.where(rng.random((11, 7)) < 0.5, 100.0, 1.0)
    first = outer_sums(phi, w)
    again = outer_sums(phi.copy(), w.copy())
    assert again is first and not first.flags.writeable
    primitive_sums._OUTER.clear()
    _bytes_equal(outer_sums(phi, w), np.asarray(first))
    w2 = w.copy()
    w2[3, 2] = 7.0
    other = outer_sums(phi, w2)
    assert other is not first and not np.array_equal(other, first)
    _bytes_equal(other, np.einsum("gcn,gcm,gd->cdnm", phi, phi, w2))
    long = rng.random((65, 5, 4)), np.ones((65, 7))
    n = len(primitive_sums._OUTER)
    outer_sums(*long)
    assert len(primitive_sums._OUTER) == n
    for k in range(OUTER_SUMS_KEPT + 1):
        outer_sums(rng.random((3, 2, 2)), np.ones((3, 2)) * k)
    assert len(primitive_sums._OUTER) == OUTER_SUMS_KEPT
    assert all(v is not first for v in primitive_sums._OUTER.values())
    primitive_sums._OUTER.clear()


def test_reactor_frame_made_only_for_a_prior(primitive_method, shake8) -> None:  # noqa: ANN001
    """The instance's frame (a gap filling) is made when a member reads a body-fit prior, and is then
    instance_frame's; without one it is not made."""
    inst = list(shake8)[5]
    view = protocol_view(inst, T0 + 1, T0)
    r = primitive_method.start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
    r.react(view, T0, T0 + 1)
    if r._plan_prior or r._primitive_prior:
        assert r._frame == instance_frame(view)
    else:
        assert r._frame is None
    r2 = primitive_method.start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
    r2._plan_prior = True  # a prior read: the frame is made (and the plan's body fit runs)
    r2.react(view, T0, T0 + 1)
    assert r2._frame == instance_frame(view)


def test_deferred_frames_are_what_a_read_candidate_lacks(rng: np.random.Generator) -> None:
    """Within T_max a candidate not read has not gained the frames deferred (its sums differ from those of every
    frame added as it came), and gains exactly them when flushed (bitwise): the flush is what makes a candidate's
    sums whole, and reading one without it would read other sums. A gap that closes (terms added otherwise) flushes
    first, so the order of every candidate's additions is kept."""
    prim, tests = _fitted(rng, "default")
    inst = tests[0]
    hidden = observed_part(inst, T0)
    new, old = PrimitiveStream(prim, T0), _OldSums(prim, T0)
    t_stop = min(inst.n_frames, int(prim.durations_.min()) - 2)
    for t in range(T0, t_stop):
        new.react_prefix_keys(hidden, t + 1, t, t + 1)
        old.react_prefix_keys(hidden, t + 1, t, t + 1)
    read = {int(new._cands.searchsorted(new.duration))}
    unread = [c for c in range(new._active, len(new._cands)) if c not in read and new._done[c] < new._log_base + len(new._log)]
    assert unread
    c = unread[0]
    assert not np.array_equal(new._hth[c], old._hth[c])
    new.flush(c)
    _bytes_equal(new._hth[c], old._hth[c])
    _bytes_equal(new._hty[c], old._hty[c])
    # A closing gap's corrections (sign −1 then +1, values only) after the deferred frames of every active candidate.
    frames = np.arange(T0 + 1, T0 + 3)
    y = np.full((2, new._n_dof), np.nan)
    y[:, 0:3] = rng.normal(size=(2, 3))
    for s_ in (new, old):
        s_._add(frames, y, -1.0, information=False)
    assert not new._log or all(new._done[k] == new._log_base + len(new._log) for k in range(new._active, len(new._cands)))
    for name in ("_hth", "_hty"):
        _bytes_equal(getattr(new, name)[new._active :], getattr(old, name)[new._active :])
