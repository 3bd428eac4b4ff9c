"""The re-planning's compiled kernels (``SynthesisConfig.kernel = "numba"``, issue 24, session 27) against the NumPy code
they replace, under the tolerance declared in docs/design.md §7: within 10⁻¹² relative on random inputs and their
edge cases (k = 1 Weibull rows, exponential rows, h = 0, NaN, −inf), −inf and NaN where NumPy gives them, and the
same discrete choices; a missing numba is a ConfigError naming the extra. Skipped without numba (except that error)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig, compiled
from socialaff_sim.inference.candidates import AGENT1, expected_error_choice
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference.row_density import RowSet
from socialaff_sim.learning.estimator import SocialAffordanceModel

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
REL = 1e-12


def _kernels():  # noqa: ANN202 (the module, imported only with numba)
    from socialaff_sim.inference.row_density import compiled_kernels

    return compiled_kernels()


def _close(got: np.ndarray, ref: np.ndarray, rel: float = REL) -> None:
    """Equal non-finite values (NaN, ±inf) where NumPy's are, and finite values within ``rel`` relative — of 1 where
    |value| < 1: a log-density near 0 is a difference of terms of order 1–100, whose last bits (10⁻¹⁵) are no
    smaller there (the declared 10⁻¹² relative, read as relative to the terms' scale)."""
    got, ref = np.asarray(got), np.asarray(ref)
    assert got.shape == ref.shape
    fin = np.isfinite(ref)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
    np.testing.assert_array_equal(got[~fin & ~np.isnan(ref)], ref[~fin & ~np.isnan(ref)])
    np.testing.assert_array_equal(np.isfinite(got), fin)
    np.testing.assert_allclose(got[fin], ref[fin], rtol=rel, atol=rel)


def test_numba_kernel_without_numba_is_a_config_error_naming_the_extra(
    monkeypatch: pytest.MonkeyPatch, shake8_model: SocialAffordanceModel
) -> None:
    monkeypatch.setattr(compiled, "available", lambda: False)
    with pytest.raises(ConfigError, match=r"kernel='numba'.*socialaff-sim\[fast\]"):
        OnlineSynthesizer(shake8_model, None, SynthesisConfig(kernel="numba"))
    OnlineSynthesizer(shake8_model, None, SynthesisConfig())  # the default needs no numba


@needs_numba
@pytest.mark.parametrize("n", [0, 1, 2, 7, 8, 9, 15, 16, 17, 127, 128, 129, 255, 256, 300, 1031])
def test_pairwise_sum_is_numpys_reduction_bitwise(rng: np.random.Generator, n: int) -> None:
    """The kernels' row sums are NumPy's pairwise order (a sequential loop differs in the last bits on these sizes)."""
    k = _kernels()
    x = rng.normal(size=(4, n + 3)) * 10.0 ** rng.integers(-8, 8, size=(4, n + 3))
    for row in x:
        assert k.pairwise_sum(row, 3, n) == row[3:].sum()
    assert np.copysign(1.0, k.pairwise_sum(np.full(n + 1, -0.0), 0, n + 1)) == np.copysign(1.0, np.full(n + 1, -0.0).sum())
    sequential = [float(np.add.accumulate(row)[-1]) for row in x]
    if n >= 16:  # the test can tell the orders apart
        assert any(s != r.sum() for s, r in zip(sequential, x, strict=True))


def _params(rng: np.random.Generator, K: int) -> np.ndarray:
    p = np.column_stack([rng.uniform(0.5, 4, K), rng.uniform(0.02, 1, K), rng.uniform(0.5, 4, K),
                         rng.uniform(0.02, 1, K), rng.uniform(-np.pi, np.pi, K), rng.uniform(0, 30, K)])
    if K > 2:
        p[1, 0] = p[2, 2] = 1.0  # k = 1 (horizontal, vertical): the 0 · log 0 convention
    if K > 4:
        p[3] = np.nan  # an absent row
        p[4, 5] = 0.0  # κ = 0: a uniform angle
    return p


def _vecs(rng: np.random.Generator, N: int, K: int) -> np.ndarray:
    v = rng.normal(scale=0.4, size=(N, K, 3))
    if N > 4 and K > 1:
        v[0, 0] = 0.0  # h = 0 and |dz| = 0: at the floors (or log 0 with ε = 0)
        v[1, 1] = np.nan
        v[2, 0] = [1e6, -1e6, 1e6]
        v[3, 1] = [1e-12, 0.0, -0.0]
        v[4, 0] = [-np.inf, 0.0, 1.0]
    return v


@needs_numba
@pytest.mark.parametrize("eps", [1e-3, 0.0])
@pytest.mark.parametrize("kind", ["weibull", "expon", "mixed"])
@pytest.mark.parametrize(("N", "K"), [(1, 1), (9, 3), (40, 9), (120, 14), (0, 5), (6, 0)])
def test_compiled_row_densities_are_numpys_within_the_tolerance(
    rng: np.random.Generator, eps: float, kind: str, N: int, K: int
) -> None:
    p = _params(rng, K)
    e = {"weibull": np.zeros(K, bool), "expon": np.ones(K, bool), "mixed": rng.random(K) < 0.5}[kind]
    if kind == "mixed" and K >= 2:
        e[:2] = [True, False]
    ref_rows, fast_rows = RowSet(p, e, eps), RowSet(p, e, eps, "numba")
    for _ in range(3):
        vecs = _vecs(rng, N, K)
        with np.errstate(all="ignore"):
            ref = ref_rows.logpdf(vecs)
        got = fast_rows.logpdf(vecs)
        assert got.shape == (N, K)
        _close(got, ref)
        if N > 4 and K > 1:
            assert np.isnan(ref[1, 1]) and np.isnan(got[1, 1])  # a NaN vector stays NaN
            if eps == 0.0 and not e[0]:
                assert not np.isfinite(ref[0, 0])  # h = 0 under a Weibull row: log 0, ±inf or NaN as NumPy's
                assert ref[0, 0] == got[0, 0] or (np.isnan(ref[0, 0]) and np.isnan(got[0, 0]))


class _Recorder(OnlineSynthesizer):
    """Records every re-planning's scoring inputs and the candidate kept."""

    def __init__(self, *a, **k) -> None:  # noqa: ANN002, ANN003
        super().__init__(*a, **k)
        self.calls: list[tuple] = []

    def _select(self, s, z, cand, before, static, prior):  # noqa: ANN001, ANN202
        best = super()._select(s, z, cand, before, static, prior)
        self.calls.append((s, z, cand.copy(), before.copy(), prior, self._score(s, z, cand, before, prior), best.copy()))
        return best


def _run(model: SocialAffordanceModel, inter, config: SynthesisConfig) -> tuple[_Recorder, list]:  # noqa: ANN001
    syn = _Recorder(model, None, config)
    syn.reset(observed_part(inter, config.n_observed), rng=np.random.default_rng(3))
    steps = []
    while not syn.done:
        steps.append(syn.step())
    return syn, steps


@needs_numba
@pytest.mark.parametrize("settings", [{}, {"vertical_sign": False}, {"end_prior": "none"}], ids=["default", "no_sign", "no_prior"])
def test_compiled_scores_and_choice_are_numpys(
    shake8_model: SocialAffordanceModel, shake8: Dataset, rng: np.random.Generator, settings: dict
) -> None:
    """Every re-planning of a synthesized instance: the compiled scores within 10⁻¹² relative of NumPy's ``_score``
    (−inf where NumPy's is), the same candidate chosen, and the reactor's outputs within 10⁻⁹ m with the same
    sub-events; then the same on the candidates with untracked (NaN) joints and with scores of −inf."""
    fast, fast_steps = _run(shake8_model, shake8[6], SynthesisConfig(kernel="numba", **settings))
    ref, ref_steps = _run(shake8_model, shake8[6], SynthesisConfig(**settings))
    assert len(fast.calls) == len(ref.calls) >= 5
    assert [s.subevent for s in fast_steps] == [s.subevent for s in ref_steps]
    for a, b in zip(fast_steps, ref_steps, strict=True):
        np.testing.assert_allclose(a.key_joints, b.key_joints, rtol=0, atol=1e-9)
    k = _kernels()
    priors = 0
    for (s, z, cand, before, prior, score, best), rec in zip(fast.calls, ref.calls, strict=True):
        np.testing.assert_array_equal(cand, rec[2])  # the draws are NumPy's, in the same order
        _close(score, rec[5])
        np.testing.assert_array_equal(best, rec[6])
        priors += prior is not None
        # Untracked joints (NaN) in some candidates, and candidates scored −inf.
        bad = cand.copy()
        bad[::7, AGENT1[1]] = np.nan
        bad[3::11, 2 * 5] = np.nan  # the object
        with np.errstate(all="ignore"):
            want = OnlineSynthesizer._score(ref, s, z, bad, before, prior)
        got = fast._score(s, z, bad, before, prior)
        _close(got, want)
        for sc in (want, np.where(rng.random(want.shape) < 0.5, -np.inf, want), np.full(want.shape, -np.inf)):
            x = bad[:, AGENT1]
            assert k.choice(bad, AGENT1, sc, 5.0) == expected_error_choice(x, sc, temperature=5.0)
    assert priors == (0 if settings.get("end_prior") == "none" else len(fast.calls))


@needs_numba
def test_compiled_choice_is_the_expected_error_choice_on_random_inputs(rng: np.random.Generator) -> None:
    """Random candidates and scores (a wide spread, ties, a single candidate, −inf, a joint NaN or infinite in every
    candidate): the compiled choice is the NumPy function's, and it is not the arg-max (inverting the choice fails)."""
    k = _kernels()
    differs = 0
    for M in (1, 2, 5, 37, 150, 300):
        for _ in range(20):
            cand = rng.normal(size=(M, 11, 3))
            score = rng.normal(scale=rng.choice([0.1, 10.0, 300.0]), size=M)
            score[rng.random(M) < 0.2] = -np.inf
            if M > 3:
                cand[:, AGENT1[2]] = np.nan  # untracked in every candidate: ignored
                cand[1, AGENT1[0], 0] = np.inf
                cand[2] = cand[3]  # a tie in distance: the first
                score[2] = score[3]
            with np.errstate(over="ignore", invalid="ignore"):  # the infinite joint's square
                want = expected_error_choice(cand[:, AGENT1], score, temperature=5.0)
            assert k.choice(cand, AGENT1, score, 5.0) == want
            if np.isfinite(score).any():
                differs += int(want != int(np.argmax(score)))
    assert differs > 10


@needs_numba
def test_type_tables_with_the_compiled_densities_are_numpys(shake8_model: SocialAffordanceModel, rng: np.random.Generator) -> None:
    """``TypeTables.of(model, "numba")`` (what the forward belief may read): every type's spatial and motion
    potentials within the tolerance of NumPy's tables, −inf where a read joint is NaN; ``TypeTables.of(model)`` stays
    NumPy's, one object per model and kernel."""
    from socialaff_sim.inference.type_tables import TypeTables

    ref, fast = TypeTables.of(shake8_model), TypeTables.of(shake8_model, "numba")
    assert ref is TypeTables.of(shake8_model) and fast is TypeTables.of(shake8_model, "numba") and ref is not fast
    assert ref.kernel == "numpy" and fast.kernel == "numba"
    end = rng.normal(scale=0.5, size=(40, 11, 3))
    end[3, 0] = np.nan
    disp = rng.normal(scale=0.1, size=(40, 11, 3))
    disp[5, 6] = np.nan
    _close(fast.spatial(end), ref.spatial(end))
    _close(fast.motion(disp), ref.motion(disp))
    for s in range(ref.S):
        _close(fast.spatial(end, s), ref.spatial(end, s))
        _close(fast.motion(disp, s), ref.motion(disp, s))
        for a, b in zip(fast.spatial_motion(end, disp, s), ref.spatial_motion(end, disp, s), strict=True):
            _close(a, b)
    assert np.isneginf(ref.spatial(end)[3]).all()


@needs_numba
def test_a_repeated_vector_keeps_its_value_but_a_signed_zero_is_not_the_same_vector(rng: np.random.Generator) -> None:
    """The kept value of a row whose vector repeats is the value NumPy gives it; (−0, 0) is not (0, 0) — arctan2 gives
    π and 0 — so keeping a value across them (comparing with ==) would fail here."""
    p = _params(rng, 3)
    p[:, 4], p[:, 5] = 0.3, 20.0  # μ, κ: the angle weighs
    rows_np, rows_nb = RowSet(p, np.zeros(3, bool), 1e-3), RowSet(p, np.zeros(3, bool), 1e-3, "numba")
    vecs = np.repeat(rng.normal(size=(1, 3, 3)), 6, axis=0)
    vecs[2:4, 1, :2] = [0.0, 0.0]
    vecs[3, 1, 0] = -0.0
    vecs[4:, 2, :2] = [-0.0, -0.0]
    vecs[5, 2, 0] = 0.0  # (0, −0): arctan2 −0, against (−0, −0): −π
    with np.errstate(all="ignore"):
        ref = rows_np.logpdf(vecs)
    assert ref[2, 1] != ref[3, 1] and ref[4, 2] != ref[5, 2]  # the signed zeros matter
    _close(rows_nb.logpdf(vecs), ref)
