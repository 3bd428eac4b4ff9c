"""The model's log-densities against scipy.stats, and their maximum-likelihood fits."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.model.densities import (
    expon_logpdf,
    fit_expon,
    fit_lognorm,
    fit_vonmises,
    fit_weibull,
    heldout_expon,
    heldout_lognorm,
    heldout_vonmises,
    heldout_weibull,
    leave_one_out_rows,
    lognorm_logpdf,
    vonmises_logpdf,
    weibull_logpdf,
)


@pytest.mark.parametrize(("k", "lam"), [(0.5, 0.2), (1.0, 1.0), (2.3, 0.7), (12.0, 0.05)])
def test_weibull_logpdf_matches_scipy(rng: np.random.Generator, k: float, lam: float) -> None:
    x = np.concatenate([rng.uniform(1e-4, 4 * lam, 200), [lam, 1e-9, 3.0]])
    np.testing.assert_allclose(weibull_logpdf(x, k, lam), stats.weibull_min(k, scale=lam).logpdf(x), rtol=1e-10, atol=1e-10)


def test_weibull_logpdf_support_and_broadcasting() -> None:
    assert weibull_logpdf(np.array(-0.1), 2.0, 1.0) == -np.inf
    np.testing.assert_allclose(weibull_logpdf(np.array(0.0), 1.0, 2.0), stats.weibull_min(1.0, scale=2.0).logpdf(0.0), atol=1e-12)
    k = np.array([[0.8], [3.0]])
    x = np.array([0.1, 0.5, 2.0])
    np.testing.assert_allclose(weibull_logpdf(x, k, 0.5), stats.weibull_min(k, scale=0.5).logpdf(x), rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize(("mu", "kappa"), [(0.0, 1e-6), (1.2, 0.5), (-2.5, 4.0), (3.0, 150.0)])
def test_vonmises_logpdf_matches_scipy(rng: np.random.Generator, mu: float, kappa: float) -> None:
    theta = rng.uniform(-np.pi, np.pi, 300)
    ref = stats.vonmises(kappa, loc=mu).logpdf(theta)
    np.testing.assert_allclose(vonmises_logpdf(theta, mu, kappa), ref, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("mean", [0.003, 0.4, 5.0])
def test_expon_logpdf_matches_scipy(rng: np.random.Generator, mean: float) -> None:
    x = rng.uniform(0, 5 * mean, 200)
    np.testing.assert_allclose(expon_logpdf(x, mean), stats.expon(scale=mean).logpdf(x), rtol=1e-10, atol=1e-10)
    assert expon_logpdf(np.array(-1.0), mean) == -np.inf


@pytest.mark.parametrize(("mu", "sigma"), [(-1.0, 0.1), (0.3, 0.6), (2.0, 1.5)])
def test_lognorm_logpdf_matches_scipy(rng: np.random.Generator, mu: float, sigma: float) -> None:
    x = np.exp(rng.normal(mu, 2 * sigma, 200))
    np.testing.assert_allclose(
        lognorm_logpdf(x, mu, sigma), stats.lognorm(sigma, scale=np.exp(mu)).logpdf(x), rtol=1e-10, atol=1e-10
    )
    assert lognorm_logpdf(np.array(0.0), mu, sigma) == -np.inf


# -- maximum likelihood ----------------------------------------------------------------------
@pytest.mark.parametrize(("k", "lam"), [(0.8, 0.3), (2.0, 1.0), (9.0, 0.04)])
def test_weibull_fit_recovers_parameters(rng: np.random.Generator, k: float, lam: float) -> None:
    x = stats.weibull_min(k, scale=lam).rvs((3, 4000), random_state=rng)
    fit = fit_weibull(x, eps=1e-12, shape_max=50.0)
    np.testing.assert_allclose(fit.shape, k, rtol=0.06)
    np.testing.assert_allclose(fit.scale, lam, rtol=0.04)


def test_weibull_fit_is_the_maximum(rng: np.random.Generator) -> None:
    """The returned log-likelihood is scipy's at the fit, and no nearby parameters do better."""
    x = stats.weibull_min(1.7, scale=0.5).rvs(60, random_state=rng)
    fit = fit_weibull(x, eps=1e-12)
    k, lam = fit.shape[0], fit.scale[0]

    def ll(kk: float, ll_: float) -> float:
        return float(stats.weibull_min(kk, scale=ll_).logpdf(x).sum())

    assert fit.loglik[0] == pytest.approx(ll(k, lam), abs=1e-9)
    h = 1e-5
    grad = [(ll(k + h, lam) - ll(k - h, lam)) / (2 * h), (ll(k, lam + h) - ll(k, lam - h)) / (2 * h)]
    np.testing.assert_allclose(grad, 0.0, atol=1e-4)
    c, _, scale = stats.weibull_min.fit(x, floc=0)
    assert fit.loglik[0] >= ll(c, scale) - 1e-9


def test_weibull_fit_degenerate_samples() -> None:
    one = fit_weibull(np.array([[0.3]]), shape_max=20.0)
    assert one.shape[0] == 20.0 and one.scale[0] == pytest.approx(0.3)
    zeros = fit_weibull(np.zeros((1, 5)), eps=1e-3, shape_max=20.0)
    assert zeros.shape[0] == 20.0 and zeros.scale[0] == pytest.approx(1e-3)
    assert np.isfinite(zeros.loglik).all()
    empty = fit_weibull(np.zeros((2, 0)))
    assert np.isnan(empty.shape).all() and (empty.loglik == 0).all()


@pytest.mark.parametrize(("mu", "kappa"), [(0.4, 0.3), (-2.0, 3.0), (3.1, 40.0)])
def test_vonmises_fit_recovers_parameters(rng: np.random.Generator, mu: float, kappa: float) -> None:
    theta = stats.vonmises(kappa, loc=mu).rvs((2, 5000), random_state=rng)
    fit = fit_vonmises(theta)
    np.testing.assert_allclose(np.angle(np.exp(1j * (fit.mu - mu))), 0.0, atol=0.3 if kappa < 1 else 0.03)  # sd of the mean direction ≈ 0.07 at κ = 0.3
    np.testing.assert_allclose(fit.kappa, kappa, rtol=0.08)
    ref = stats.vonmises(fit.kappa[0], loc=fit.mu[0]).logpdf(theta[0]).sum()
    assert fit.loglik[0] == pytest.approx(ref, abs=1e-8)


def test_vonmises_fit_matches_scipy_fit(rng: np.random.Generator) -> None:
    theta = stats.vonmises(2.0, loc=1.0).rvs(300, random_state=rng)
    kappa, loc, _ = stats.vonmises.fit(theta, fscale=1)
    fit = fit_vonmises(theta)
    assert fit.kappa[0] == pytest.approx(kappa, rel=1e-6)
    assert fit.mu[0] == pytest.approx(loc, abs=1e-8)


def test_vonmises_fit_caps_kappa() -> None:
    fit = fit_vonmises(np.full((1, 4), 0.7), kappa_max=50.0)
    assert fit.kappa[0] == 50.0 and fit.mu[0] == pytest.approx(0.7)
    ref = stats.vonmises(50.0, loc=0.7).logpdf(np.full(4, 0.7)).sum()
    assert fit.loglik[0] == pytest.approx(ref, abs=1e-9)


def test_expon_fit(rng: np.random.Generator) -> None:
    x = stats.expon(scale=0.25).rvs((2, 5000), random_state=rng)
    fit = fit_expon(x, eps=1e-9)
    np.testing.assert_allclose(fit.mean, 0.25, rtol=0.05)
    np.testing.assert_allclose(fit.loglik, stats.expon(scale=fit.mean[:, None]).logpdf(x).sum(axis=1), rtol=1e-12)
    assert fit_expon(np.zeros((1, 3)), eps=1e-3).mean[0] == pytest.approx(1e-3)


def test_lognorm_fit(rng: np.random.Generator) -> None:
    x = stats.lognorm(0.4, scale=np.exp(0.2)).rvs((2, 5000), random_state=rng)
    fit = fit_lognorm(x)
    np.testing.assert_allclose(fit.mu, 0.2, atol=0.02)
    np.testing.assert_allclose(fit.sigma, 0.4, rtol=0.04)
    ref = stats.lognorm(fit.sigma[:, None], scale=np.exp(fit.mu[:, None])).logpdf(x).sum(axis=1)
    np.testing.assert_allclose(fit.loglik, ref, rtol=1e-10)
    _, _, scale = stats.lognorm.fit(x[0], floc=0)
    assert np.log(scale) == pytest.approx(fit.mu[0], abs=1e-6)


def test_lognorm_fit_floors_sigma() -> None:
    x = np.full((1, 3), 1.5)
    fit = fit_lognorm(x, sigma_min=0.05)
    assert fit.sigma[0] == 0.05
    ref = stats.lognorm(0.05, scale=1.5).logpdf(x[0]).sum()
    assert fit.loglik[0] == pytest.approx(ref, rel=1e-10)


def _brute_heldout(x: np.ndarray, fit, logpdf) -> np.ndarray:  # noqa: ANN001
    """Σ_n logpdf(x_n | fit(x without n)) per row, by an explicit loop (the reference)."""
    out = np.zeros(x.shape[0])
    for b in range(x.shape[0]):
        for n in range(x.shape[1]):
            params = fit(np.delete(x[b], n))
            out[b] += logpdf(x[b, n], *params)
    return out


def test_leave_one_out_rows() -> None:
    x = np.arange(8.0).reshape(2, 4)
    rows = leave_one_out_rows(x)
    assert rows.shape == (2, 4, 3)
    for b in range(2):
        for n in range(4):
            np.testing.assert_array_equal(rows[b, n], np.delete(x[b], n))


def test_heldout_loglik_matches_a_brute_force_loop(rng: np.random.Generator) -> None:
    """Held-out log-likelihoods: each sample under the fit without it, scored by scipy.stats."""
    x = rng.weibull(2.0, (3, 9)) * 0.4 + 1e-4
    theta = rng.vonmises(0.5, 3.0, (3, 9))
    eps = 1e-3

    def wfit(v):  # noqa: ANN001, ANN202
        f = fit_weibull(v, eps=eps)
        return float(f.shape[0]), float(f.scale[0])

    ref = _brute_heldout(np.maximum(x, eps), wfit, lambda v, k, lam: stats.weibull_min.logpdf(v, k, scale=lam))
    np.testing.assert_allclose(heldout_weibull(x, eps=eps), ref, rtol=1e-9)

    def vfit(v):  # noqa: ANN001, ANN202
        f = fit_vonmises(v)
        return float(f.mu[0]), float(f.kappa[0])

    ref = _brute_heldout(theta, vfit, lambda v, mu, kap: stats.vonmises.logpdf(v, kap, loc=mu))
    np.testing.assert_allclose(heldout_vonmises(theta), ref, rtol=1e-9)
    ref = _brute_heldout(np.maximum(x, eps), lambda v: (float(np.mean(v)),), lambda v, m: stats.expon.logpdf(v, scale=m))
    np.testing.assert_allclose(heldout_expon(x, eps=eps), ref, rtol=1e-9)

    def lfit(v):  # noqa: ANN001, ANN202
        f = fit_lognorm(v, sigma_min=0.05)
        return float(f.mu[0]), float(f.sigma[0])

    ref = _brute_heldout(x, lfit, lambda v, mu, sig: stats.lognorm.logpdf(v, sig, scale=np.exp(mu)))
    np.testing.assert_allclose(heldout_lognorm(x, sigma_min=0.05), ref, rtol=1e-9)


def test_heldout_loglik_is_below_the_maximized_one_and_falls_back_for_one_sample(rng: np.random.Generator) -> None:
    x = rng.weibull(1.5, (4, 12))
    assert np.all(heldout_weibull(x) < fit_weibull(x).loglik)
    assert np.all(heldout_expon(x) < fit_expon(x).loglik)
    one = np.array([[0.3]])
    np.testing.assert_allclose(heldout_weibull(one), fit_weibull(one).loglik, atol=0.0)
    np.testing.assert_allclose(heldout_vonmises(one), fit_vonmises(one).loglik, atol=0.0)
    np.testing.assert_allclose(heldout_expon(one), fit_expon(one).loglik, atol=0.0)
    np.testing.assert_allclose(heldout_lognorm(one), fit_lognorm(one).loglik, atol=0.0)
    # Near-identical samples: the maximized fit hugs them; one sample apart costs the held-out score dearly.
    tight = np.array([[0.5] * 8 + [0.8]])
    assert heldout_weibull(tight)[0] < fit_weibull(tight).loglik[0] - 20.0
