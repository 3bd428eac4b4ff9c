"""The primitive stream's compiled kernel (kernel="numba", inference/primitive_kernel.py): the rank-k update of the
a-block's Cholesky factor against numpy.linalg.cholesky of the updated matrix, the stream with the kernel against the
NumPy stream frame by frame (within the declared 1e-9 m), when the factor is updated and when it is made anew, and a
missing numba's ConfigError. Skipped without numba, but for the error."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import compiled, primitive_kernel
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.primitive_kernel import UpdatedFactor, cholesky_update, cholesky_update_python
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.protocol import protocol_view

from test_primitive_stream import T0, _instances

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")

# A factor update is not a factorisation: its error is bounded by the factor's conditioning, not by 1e-12. The
# matrices below have condition numbers 1e2–1e5 (asserted); a backward-stable rank-one update adds O(n ε) relative
# error per vector to L, so 1e-10 relative (max-norm) leaves a factor of ≥ 10 above n·V·ε = 216·36·2.2e-16 ≈ 1.7e-12.
FACTOR_RTOL = 1e-10


def _spd(rng: np.random.Generator, n: int, cond: float) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    m = (q * np.geomspace(1.0, 1.0 / cond, n)) @ q.T
    return 0.5 * (m + m.T)


def _updated(m: np.ndarray, phi: np.ndarray, frame: np.ndarray, dof: np.ndarray, root_w: np.ndarray, nb: int) -> np.ndarray:
    """M + Σ_v x_v x_vᵀ built explicitly (the reference)."""
    out = m.copy()
    for f, d, r in zip(frame, dof, root_w, strict=True):
        x = np.zeros(len(m))
        x[d * nb : d * nb + nb] = r * phi[f]
        out += np.outer(x, x)
    return out


@needs_numba
@pytest.mark.parametrize("n_blocks, nb, cond", [(18, 12, 1e3), (4, 6, 1e5), (1, 5, 1e2), (7, 3, 1e4)])
def test_factor_update_equals_the_factor_of_the_updated_matrix(rng: np.random.Generator, n_blocks: int, nb: int,
                                                               cond: float) -> None:
    n = n_blocks * nb
    m = _spd(rng, n, cond)
    assert np.linalg.cond(m) == pytest.approx(cond, rel=1e-6)
    lower = np.asfortranarray(np.linalg.cholesky(m))
    # Two frames: every block in the first, a subset (not starting at block 0) in the second, unequal weights, a
    # basis row with a zero entry (the rotation that leaves a column as it is).
    phi = rng.normal(size=(2, nb))
    phi[1, 0] = 0.0
    sub = np.arange(n_blocks)[n_blocks // 2 :]
    frame = np.r_[np.zeros(n_blocks, np.int64), np.ones(len(sub), np.int64)]
    dof = np.r_[np.arange(n_blocks), sub].astype(np.int64)
    root_w = np.sqrt(rng.uniform(0.5, 400.0, len(dof)))
    got = lower.copy(order="F")
    cholesky_update(got.T, phi, frame, dof, root_w, nb)
    ref = np.linalg.cholesky(_updated(m, phi, frame, dof, root_w, nb))
    assert np.max(np.abs(np.tril(got) - ref)) <= FACTOR_RTOL * np.max(np.abs(ref))
    assert np.array_equal(np.triu(got, 1), np.triu(lower, 1))  # the upper triangle is not touched
    # The compiled loop is the Python loop's arithmetic (no fast-math): equal to rounding of the same operations.
    slow = lower.copy(order="F")
    cholesky_update_python(slow.T, phi, frame, dof, root_w, nb)
    assert np.max(np.abs(got - slow)) <= 1e-12 * np.max(np.abs(ref))


@needs_numba
def test_factor_update_edge_cases(rng: np.random.Generator) -> None:
    m = _spd(rng, 12, 10.0)
    lower = np.asfortranarray(np.linalg.cholesky(m))
    none = np.zeros(0, np.int64)
    same = lower.copy(order="F")
    cholesky_update(same.T, np.ones((1, 4)), none, none, np.zeros(0), 4)  # no vector: nothing changes
    assert np.array_equal(same, lower)
    zero = lower.copy(order="F")
    cholesky_update(zero.T, np.zeros((1, 4)), np.zeros(1, np.int64), np.array([1]), np.ones(1), 4)  # x = 0
    assert np.array_equal(zero, lower)
    last = lower.copy(order="F")  # the last block only: columns before it unchanged
    phi = rng.normal(size=(1, 4))
    cholesky_update(last.T, phi, np.zeros(1, np.int64), np.array([2]), np.array([3.0]), 4)
    assert np.array_equal(last[:, :8], lower[:, :8])
    ref = np.linalg.cholesky(_updated(m, phi, np.zeros(1, np.int64), np.array([2]), np.array([3.0]), 4))
    assert np.max(np.abs(np.tril(last) - ref)) <= FACTOR_RTOL * np.max(np.abs(ref))


def _streams(prim: InteractionPrimitive, inst) -> tuple[float, list[tuple[int, int]]]:  # noqa: ANN001
    """Max |numba − numpy| (metres) of the two streams frame by frame within T_max, and per frame (candidate, factor
    age after the read) of the compiled stream."""
    ref, fast = PrimitiveStream(prim, T0), PrimitiveStream(prim, T0, "numba")
    worst, seen = 0.0, []
    for t in range(T0, min(inst.n_frames, ref.t_max)):
        view = protocol_view(inst, t + 1, T0)
        a, b = ref.react_keys(view, t, t + 1), fast.react_keys(view, t, t + 1)
        assert ref.duration == fast.duration  # the duration chosen is the same (the kernel does not touch the match)
        assert np.array_equal(np.isnan(a), np.isnan(b))
        worst = max(worst, float(np.nanmax(np.abs(a - b))))
        assert fast._factor is not None
        seen.append((fast._factor.candidate, fast._factor.age))
    return worst, seen


@needs_numba
@pytest.mark.parametrize("with_object", [True, False])
def test_compiled_stream_is_within_the_declared_tolerance_of_numpys(rng: np.random.Generator, with_object: bool,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    insts = _instances(rng, 9, gaps=True, with_object=with_object)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=6)).fit(insts[3:])
    updated = renewed = 0
    for inst in insts[:3]:
        worst, seen = _streams(prim, inst)
        assert worst < 1e-9
        for (c0, _), (c1, age1) in zip(seen, seen[1:], strict=False):
            if c1 != c0:  # another candidate: its a-block factored anew
                assert age1 == 0
                renewed += 1
            updated += age1 > 0
    assert updated > 10 and renewed > 0  # both paths ran
    # Compiled once, for the types the stream passes (no compilation at a stream's first frame).
    assert len(primitive_kernel.kernels()["cholesky_update"].signatures) == 1


@needs_numba
def test_factor_is_renewed_after_the_renewal_frames(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(primitive_kernel, "FACTOR_RENEWAL", 3)
    insts = _instances(rng, 7, gaps=False)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=2)).fit(insts[1:])
    worst, seen = _streams(prim, insts[0])
    assert worst < 1e-9
    ages = [age for _, age in seen]
    assert max(ages) == 3 and ages.count(0) >= 2  # updated over 3 frames at most, then factored anew


def test_numba_kernel_without_numba_is_a_config_error(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: False)
    monkeypatch.setattr(compiled, "_ONCE", {})  # as in a new process: nothing compiled yet
    prim = InteractionPrimitive(ProMPConfig(n_basis=4, n_durations=2)).fit(_instances(rng, 4))
    with pytest.raises(ConfigError, match=r"socialaff-sim\[fast\]"):
        PrimitiveStream(prim, T0, "numba")
    with pytest.raises(ConfigError, match="kernel: expected"):
        PrimitiveStream(prim, T0, "cython")
    assert PrimitiveStream(prim, T0)._factor is None  # the NumPy path keeps no factor


def test_updated_factor_bookkeeping() -> None:
    f = UpdatedFactor()
    f.record(5, np.array([0]), np.array([1.0]))
    assert not f.frames and not f.usable(0)  # nothing factored: nothing recorded
    buffer, chol = np.zeros((2, 2), order="F"), np.asfortranarray(np.eye(2))
    f.factored(2, chol, buffer)
    assert f.usable(2) and not f.usable(1) and np.array_equal(buffer, chol)  # the factor kept where it is updated
    f.record(6, np.array([0, 1]), np.array([1.0, 1.0]))
    assert len(f.frames) == 1
    f.forget()
    assert not f.usable(2) and not f.frames
