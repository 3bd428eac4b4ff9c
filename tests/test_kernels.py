"""The compiled densities (``SynthesisConfig.kernel = "numba"``, issue 24's speed probe; off by default) against the
NumPy path they stand in for: the type tables' spatial and motion log-potentials within 10⁻¹² relative (not bitwise:
other exp, log and cos, and the scalar forms of docs/design.md §7), on candidates with NaN joints, zero vectors (h and
|dz| at their floor) and exponential rows; the option's validation and its default."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import kernels
from socialaff_sim.inference.synthesis import SynthesisConfig
from socialaff_sim.inference.type_tables import TypeTables


def test_the_default_is_numpy_and_other_values_are_refused() -> None:
    assert SynthesisConfig().kernel == "numpy" and SynthesisConfig.reactive().kernel == "numpy"
    assert SynthesisConfig.paper().kernel == "numpy"
    with pytest.raises(ConfigError, match="kernel"):
        SynthesisConfig(kernel="fortran")


def test_numba_missing_is_a_config_error(monkeypatch: pytest.MonkeyPatch, shake8_model) -> None:  # noqa: ANN001
    monkeypatch.setattr(kernels, "available", lambda: False)
    monkeypatch.setattr(kernels, "_compiled", None)
    tab = TypeTables.of(copy.copy(shake8_model))
    with pytest.raises(ConfigError, match=r"numba is not installed.*\[fast\]"):
        tab.spatial(np.zeros((2, 11, 3)), 0, kernel="numba")


def test_compiled_densities_are_numpys_within_1e_12(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    pytest.importorskip("numba")
    model = copy.copy(shake8_model)
    tab = TypeTables.of(model)
    end = rng.normal(scale=0.5, size=(60, 11, 3))
    end[3, 2] = np.nan  # a joint unknown: NaN rows, −inf scores
    end[5] = 0.0  # every vector zero: h and |dz| at their floor, θ = atan2(0, 0)
    end[7, :, 2] = 0.0
    for s in (None, *range(model.n_subevents_)):
        for f in (tab.spatial, tab.motion):
            ref, got = f(end, s), f(end, s, kernel="numba")
            assert ref.shape == got.shape
            finite = np.isfinite(ref)
            assert np.array_equal(finite, np.isfinite(got)) and np.array_equal(ref[~finite], got[~finite])
            np.testing.assert_allclose(got[finite], ref[finite], rtol=1e-12, atol=0)


def test_compiled_rows_with_exponential_rows_are_numpys(rng: np.random.Generator) -> None:
    """A row set of both kinds (exponential rows, Weibull rows with k = 1 and k ≠ 1): the kernel against
    polar_rows_logpdf of polar, the NumPy path, within 10⁻¹² relative."""
    pytest.importorskip("numba")
    from scipy.special import i0e

    from socialaff_sim.model.densities import weibull_terms
    from socialaff_sim.model.features import polar
    from socialaff_sim.model.potentials import polar_rows_logpdf

    R = 7
    params = np.column_stack([rng.uniform(0.8, 3, R), rng.uniform(0.05, 0.6, R), rng.uniform(0.8, 3, R),
                              rng.uniform(0.05, 0.6, R), rng.uniform(-np.pi, np.pi, R), rng.uniform(0.1, 20, R)])
    params[2, 0] = params[4, 2] = 1.0  # k = 1: the 0 · log 0 convention's branch
    expon = np.zeros(R, bool)
    expon[[1, 5]] = True
    log_i0e = np.log(i0e(params[:, 5]))
    rows = (params, expon, log_i0e, (weibull_terms(params[:, 0], params[:, 1]), weibull_terms(params[:, 2], params[:, 3])))
    vecs = rng.normal(scale=0.4, size=(50, R, 3))
    vecs[0] = 0.0
    vecs[1, :, :2] = 0.0
    vecs[2, 3] = np.nan
    eps = 1e-3
    with np.errstate(divide="ignore", invalid="ignore"):
        ref = polar_rows_logpdf(*polar(vecs, eps), params, expon, log_i0e=log_i0e)
    got = kernels.polar_rows(vecs, rows, eps)
    finite = np.isfinite(ref)
    assert np.array_equal(finite, np.isfinite(got)) and np.isnan(got[2, 3])
    np.testing.assert_allclose(got[finite], ref[finite], rtol=1e-12, atol=0)
