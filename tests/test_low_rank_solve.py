"""LowRankUpdatedSolver (the Woodbury solve of A + U diag(d) Uᵀ) against numpy.linalg.solve on the explicit
matrix; and the interaction primitive's stream past T_max: its low-rank solves against the stream refactoring at
every frame and against numpy.linalg.solve of the explicitly built a-block, on a stream 20 times T_max long, and the
decision points (which frames take the low-rank path, and when the factor is renewed)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ModelError
from socialaff_sim.inference import primitive_stream
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.low_rank_solve import LowRankUpdatedSolver
from socialaff_sim.inference.primitive_conditioning import add_blocks
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.protocol import protocol_view

T0 = 10
REL = 1e-9  # the tolerance declared in docs/design.md §8 (relative, max-norm)


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    x = rng.normal(size=(n, n))
    return x @ x.T + n * np.eye(n)


def test_low_rank_solve_equals_the_direct_solve(rng: np.random.Generator) -> None:
    n, m = 40, 6
    a = _spd(rng, n)
    u = rng.normal(size=(n, m))
    solver = LowRankUpdatedSolver(a.copy(), u)
    b = rng.normal(size=n)
    # Weights zero: A's own solve.
    assert np.allclose(solver.solve(b), np.linalg.solve(a, b), rtol=0, atol=1e-12 * np.abs(np.linalg.solve(a, b)).max())
    for d in (np.array([1.0, 0, 0, 0, 0, 0]), rng.uniform(0, 5, m), np.array([0, 3e4, 0, 1e4, 2.0, 0]), np.full(m, 1e6)):
        solver.weights[:] = d
        ref = np.linalg.solve(a + (u * d) @ u.T, b)
        got = solver.solve(b)
        assert np.abs(got - ref).max() <= REL * np.abs(ref).max()
    # A weight that is ignored would fail: the update changes the answer.
    solver.weights[:] = 0.0
    assert np.abs(solver.solve(b) - np.linalg.solve(a + 10.0 * np.outer(u[:, 0], u[:, 0]), b)).max() > 1e-6


def test_low_rank_solver_checks_its_input(rng: np.random.Generator) -> None:
    with pytest.raises(ModelError, match="not positive definite"):
        LowRankUpdatedSolver(-np.eye(4), np.ones((4, 1)))
    with pytest.raises(ModelError, match="expected A"):
        LowRankUpdatedSolver(np.eye(4), np.ones((3, 1)))


def _reach(rng: np.random.Generator, T: int, k: int) -> Interaction:
    """Agent 0 moves a wrist (and an object with it) back and forth, agent 1 mirrors it; on a stream of more than
    200 frames agent 0's right wrist has a tracking gap and its left ankle is first tracked at frame 220. The
    motion keeps going, so a long stream's phase-1 observations carry information."""
    body0 = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
    body1 = body0 * [-1, -1, 1] + [1.4, 0, 0]
    s = np.arange(T) / 10.0
    a0 = np.repeat(body0[None], T, 0) + rng.normal(0, 0.005, (T, 5, 3))
    a1 = np.repeat(body1[None], T, 0) + rng.normal(0, 0.005, (T, 5, 3))
    bump = 0.3 * np.sin(rng.uniform(0.5, 1.5) * s)
    a0[:, 1, 0] += bump
    a1[:, 2, 0] -= bump
    valid = np.ones((T, 2, 5), bool)
    if T > 200:  # past T_max: a wrist's tracking gap (held, then interpolated when it closes), and the left ankle
        valid[150:170, 0, 2] = False  # first tracked at frame 220 (the stream rebuilds its sums: a new factor)
        valid[:220, 0, 3] = False
    return Interaction("reach", 10.0, np.stack([a0, a1], 1), KEY_JOINTS, ("p", "q"), object=a0[:, 1] + [0.05, 0, 0],
                       valid=valid, instance_id=f"r{k:02d}")


def _a_block(stream: PrimitiveStream) -> tuple[np.ndarray, np.ndarray]:
    """The conditioning's a-block S + B_a and right-hand side of the stream's current candidate, built explicitly."""
    c = int(np.argmax(stream._cands))
    s_aa, _, _, p_u = stream._solver(c)
    d0 = stream._d0
    lam = add_blocks(s_aa.copy(), stream._hth[c, :d0])
    rhs = (stream._hty[c, :d0] - np.einsum("dnm,dm->dn", stream._hth[c, :d0], stream._mean[:d0])).ravel() - p_u
    return lam, rhs


def test_past_t_max_the_low_rank_solves_equal_the_direct_ones(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    train = [_reach(rng, int(rng.integers(25, 31)), k) for k in range(8)]
    prim = InteractionPrimitive(ProMPConfig(n_basis=6, n_durations=4)).fit(train)
    t_max = int(prim.durations_.max())
    long = _reach(rng, 20 * t_max, 99)
    refactor = 64
    monkeypatch.setattr(primitive_stream, "PHASE_ONE_REFACTOR", refactor)
    low, direct = PrimitiveStream(prim, T0), PrimitiveStream(prim, T0)
    solved: list[np.ndarray] = []
    real_solve = LowRankUpdatedSolver.solve

    def spy(self: LowRankUpdatedSolver, b: np.ndarray) -> np.ndarray:
        x = real_solve(self, b)
        solved.append(x)
        return x

    monkeypatch.setattr(LowRankUpdatedSolver, "solve", spy)
    worst_w, worst_keys, used, refactored, rebuilt = 0.0, 0.0, 0, 0, 0
    for t in range(T0, long.n_frames):
        view = protocol_view(long, t + 1, T0)
        n_before = len(solved)
        got = low.keys(view, t, t + 1)
        took_low_rank = len(solved) > n_before
        # The decision point: the low-rank path exactly from the frame where T_max frames are seen.
        assert took_low_rank == (t + 1 >= t_max)
        if took_low_rank:
            used += 1
            assert low._phase_one is not None
            refactored += int(not low._phase_one.weights.any())
            rebuilt += int(t == 220)
            lam, rhs = _a_block(low)
            ref = np.linalg.solve(lam, rhs)
            worst_w = max(worst_w, float(np.abs(solved[-1] - ref).max() / np.abs(ref).max()))
        with monkeypatch.context() as m:  # the same frame with a factor renewed at every frame: the direct solve
            m.setattr(primitive_stream, "PHASE_ONE_REFACTOR", 0)
            want = direct.keys(view, t, t + 1)
        assert np.array_equal(np.isnan(got), np.isnan(want))
        worst_keys = max(worst_keys, float(np.nanmax(np.abs(got - want))))
    assert used == long.n_frames - t_max + 1
    # Renewed at the first such frame, then every `refactor` phase-1 frames, and once more where the late-tracked
    # ankle rebuilt the sums (frame 220, mid-period: the solve there is checked against the direct one above).
    assert rebuilt == 1 and (220 - (t_max - 1)) % refactor != 0
    assert refactored == -(-(220 - (t_max - 1)) // refactor) + -(-(long.n_frames - 220) // refactor)
    assert worst_w <= REL
    assert worst_keys <= 1e-9  # metres
    # The low-rank term matters: without it (weights ignored) the weights would be those of a stale factor.
    lam, rhs = _a_block(low)
    stale = low._phase_one
    assert stale is not None and stale.weights.any()
    keep = stale.weights.copy()
    stale.weights[:] = 0.0
    assert np.abs(stale.solve(rhs) - np.linalg.solve(lam, rhs)).max() > 1e3 * REL * np.abs(np.linalg.solve(lam, rhs)).max()
    stale.weights[:] = keep


def test_equal_weights_take_the_eigendecomposed_capacitance(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    """Equal non-zero weights on a subset of U's columns (the stream's usual frame) solve through the eigenvectors of
    C_SS, made once per subset; unequal weights through the m×m system; both within the declared tolerance of
    numpy.linalg.solve on the explicit matrix (docs/design.md §7)."""
    n, m = 48, 8
    a = _spd(rng, n)
    u = rng.normal(size=(n, m))
    solver = LowRankUpdatedSolver(a.copy(), u)
    eighs: list[int] = []
    real_eigh = np.linalg.eigh

    def spy(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        eighs.append(len(x))
        return real_eigh(x)

    monkeypatch.setattr(np.linalg, "eigh", spy)
    subset = np.array([1.0, 1, 0, 1, 0, 1, 1, 0])
    for d in (5.0 * subset, 7.0 * subset, np.full(m, 1e4), 5.0 * subset, np.array([1.0, 2, 0, 3, 0, 4, 5, 6])):
        solver.weights[:] = d
        b = rng.normal(size=n)
        ref = np.linalg.solve(a + (u * d) @ u.T, b)
        assert np.abs(solver.solve(b) - ref).max() <= REL * np.abs(ref).max()
    # 5 columns; the same 5 with another δ (reused); all 8; the 5 again (remade); unequal weights (the m×m system).
    assert eighs == [5, 8, 5]
