"""The interaction primitive's per-frame shortcuts (issue 24, real-time speed) against the computations they replace,
bitwise: the per-frame sums (basis table, candidate and DoF runs as slices) against the gathered sums of ``_add_rows``,
the candidate choice by ``searchsorted`` against the scan of every candidate, the a-block built in a Fortran buffer
against ``add_blocks``; on instances with tracking gaps, a joint first tracked late, a joint never tracked (two runs of
DoFs) and a stream past the longest training duration."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.growing import GrowingInteraction
from socialaff_sim.inference import primitive_stream
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig, rbf_basis
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.primitive_sums import _runs
from socialaff_sim.inference.protocol import observed_part

from test_primitive_stream import _instances
from test_reactor_stream import _repeat

T0 = 10


def _outputs(prim: InteractionPrimitive, inst: Interaction) -> tuple[np.ndarray, list[int], int]:
    """Agent 1's key joints at every causal frame (and every 5th frame the next 4 as well), the durations chosen and
    the most runs of seen DoFs in a frame."""
    stream = PrimitiveStream(prim, T0)
    hidden = observed_part(inst, T0)
    views = GrowingInteraction(hidden)
    out, durations = [], []
    for t in range(T0, inst.n_frames):
        views.append_from(hidden, t + 1)
        out.append(stream.react_keys(views.view(), t, t + 1 if t % 5 else t + 5))
        durations.append(int(stream.duration or 0))
    return np.concatenate(out), durations, max((len(p.runs) for p in stream._col_runs.values()), default=0)


def _never_tracked(inst: Interaction, joint: int) -> Interaction:
    """``inst`` with agent 0's key joint ``joint`` never tracked (its DoFs never seen: the seen DoFs form two runs)."""
    valid = np.array(inst.valid, copy=True)
    valid[:, 0, joint] = False
    return inst.replace(valid=valid)


def _old_choose(self: PrimitiveStream, at_least: int) -> int:
    eligible = np.flatnonzero(self._cands >= at_least)
    if eligible.size == 0:
        return int(np.argmax(self._cands))
    if eligible.size == 1:
        return int(eligible[0])
    return int(eligible[np.argmin(self._err[eligible])])


def test_per_frame_shortcuts_equal_the_gathered_sums(monkeypatch: pytest.MonkeyPatch) -> None:
    insts = _instances(np.random.default_rng(11), 8, gaps=True)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(insts[3:])
    tests = [insts[0], insts[1], _never_tracked(insts[2], 1), _repeat(_never_tracked(insts[1], 2), 4)]
    factored: list[np.ndarray] = []
    real_potrf = primitive_stream.dpotrf

    def spy(a: np.ndarray, **kw: int) -> tuple[np.ndarray, int]:
        factored.append(np.array(a))
        return real_potrf(a, **kw)

    monkeypatch.setattr(primitive_stream, "dpotrf", spy)
    new = [_outputs(prim, inst) for inst in tests]
    # The reference: every frame's sums by _add_rows (gathers), the old choice, the a-block by add_blocks.
    built: list[np.ndarray] = []

    def old_potrf(a: np.ndarray, **kw: int) -> tuple[np.ndarray, int]:
        built.append(np.array(a))
        return real_potrf(np.ascontiguousarray(a), **kw)

    with monkeypatch.context() as m:
        m.setattr(PrimitiveStream, "_add_frame", lambda self, s, y: self._add_rows(np.array([s]), y[None]))
        m.setattr(PrimitiveStream, "_choose", _old_choose)
        m.setattr(primitive_stream, "dpotrf", old_potrf)
        old = [_outputs(prim, inst) for inst in tests]
    for (a, da, _), (b, db, _) in zip(new, old, strict=True):
        assert da == db
        assert np.array_equal(a, b, equal_nan=True)
    assert len(factored) == len(built) > 0 and all(np.array_equal(x, y) for x, y in zip(factored, built, strict=True))
    assert all(f.flags.f_contiguous for f in factored)
    # The cases the shortcuts branch on occur: two runs of seen DoFs, a stream past T_max, more than one duration.
    assert new[2][2] >= 2 and new[3][2] >= 2
    assert len(new[3][1]) > 2 * int(prim.durations_.max()) and len(set(new[0][1])) > 1


def test_the_basis_table_equals_rbf_basis() -> None:
    insts = _instances(np.random.default_rng(2), 6)
    prim = InteractionPrimitive(ProMPConfig(n_basis=7, n_durations=5)).fit(insts)
    stream = PrimitiveStream(prim, T0)
    for c, duration in enumerate(stream._cands):
        for s in range(0, stream.t_max + 30, 3):
            want = rbf_basis(np.minimum(np.array([s]) / max(duration - 1, 1), 1.0), 7)[0]
            assert np.array_equal(stream._table[min(s, stream.t_max), c], want)


def test_runs_of_columns() -> None:
    for cols in ([], [4], [0, 1, 2], [0, 1, 2, 6, 7, 9], [3, 5, 7]):
        c = np.array(cols, dtype=np.int64)
        runs = _runs(c)
        assert np.array_equal(np.concatenate([np.arange(a, b) for a, b, _, _ in runs]) if runs else c, c)
        assert all(np.array_equal(c[i:j], np.arange(a, b)) for a, b, i, j in runs)
        assert len(runs) == (0 if not cols else 1 + int((np.diff(c) != 1).sum()))
