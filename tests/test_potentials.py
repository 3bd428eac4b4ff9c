"""Canonical frame, interval features and the spatial / motion potentials."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data import KEY_JOINTS, Interaction
from socialaff_sim.errors import DataError, ModelError
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.features import interval_features, polar
from socialaff_sim.model.frame import CanonicalFrame, canonical_frame
from socialaff_sim.model.joints import JOINT_NAMES, LONE_REFERENCE, N_JOINTS, OBJECT, canonical_joints
from socialaff_sim.model.potentials import TypePotentials, fit_type_potentials, log_motion, log_spatial, reference_weights


def test_canonical_frame_axes_and_round_trip(rng: np.random.Generator) -> None:
    b0, b1 = np.array([1.0, 2.0, 0.9]), np.array([-1.0, 4.0, 1.0])
    frame = canonical_frame(b0, b1)
    c0, c1 = frame.to_canonical(b0), frame.to_canonical(b1)
    np.testing.assert_allclose(c0, [0, 0, 0.9], atol=1e-12)  # origin: base 0 on the floor
    np.testing.assert_allclose(c1, [np.hypot(2, 2), 0, 1.0], atol=1e-12)  # x axis toward base 1
    pts = rng.normal(size=(4, 5, 3))
    np.testing.assert_allclose(frame.to_world(frame.to_canonical(pts)), pts, atol=1e-12)
    R = frame.rotation
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    v = rng.normal(size=(3,))
    np.testing.assert_allclose(frame.vectors_to_world(frame.to_canonical(v) - frame.to_canonical(np.zeros(3))), v, atol=1e-12)


def test_canonical_frame_degenerate_and_invalid() -> None:
    frame = canonical_frame(np.array([0.5, 0.5, 1.0]), np.array([0.5, 0.5, 1.2]))
    assert frame.heading == 0.0
    with pytest.raises(DataError, match="finite"):
        canonical_frame(np.array([np.nan, 0, 0]), np.zeros(3))


def test_canonical_frames_compare_by_value_and_hash_alike() -> None:
    b0, b1 = np.array([1.0, 2.0, 0.9]), np.array([-1.0, 4.0, 1.0])
    a, b = canonical_frame(b0, b1), canonical_frame(b0.copy(), b1.copy())
    assert a is not b and a == b and not (a != b) and hash(a) == hash(b)
    assert len({a, b}) == 1 and {a: 1}[b] == 1  # usable as a key, by value
    moved = CanonicalFrame(origin=a.origin + [0.0, 1e-9, 0.0], heading=a.heading)  # origin differs, heading alike
    turned = CanonicalFrame(origin=a.origin.copy(), heading=a.heading + 1e-9)  # heading differs, origin alike
    assert a != moved and a != turned and not (a == moved) and not (a == turned)
    # -0.0 and 0.0 are the same point: equal frames, equal hashes.
    z = CanonicalFrame(origin=np.array([0.0, 0.0, 0.0]), heading=0.0)
    nz = CanonicalFrame(origin=np.array([-0.0, 0.0, -0.0]), heading=-0.0)
    assert z == nz and hash(z) == hash(nz)
    assert a != "a frame" and a != (a.origin, a.heading)  # other types are never equal
    np.testing.assert_array_equal(a.rotation, b.rotation)


def _instance(rng: np.random.Generator, with_object: bool) -> Interaction:
    T = 12
    joints = rng.normal(0, 0.2, (T, 2, 5, 3)) + np.array([[0, 0, 1.0], [2.0, 1.0, 1.0]])[None, :, None, :]
    obj = rng.normal(0, 0.1, (T, 3)) + [1.0, 0.5, 1.0] if with_object else None
    return Interaction(label="hand_over", fps=10.0, joints=joints, joint_names=KEY_JOINTS, actors=("a", "b"), object=obj)


def test_canonical_joints(rng: np.random.Generator) -> None:
    inter = _instance(rng, with_object=False)
    x = canonical_joints(inter)
    assert x.shape == (12, N_JOINTS, 3) and len(JOINT_NAMES) == N_JOINTS
    assert np.isnan(x[:, OBJECT]).all() and np.isfinite(x[:, :OBJECT]).all()
    np.testing.assert_allclose(x[0, 0, :2], 0.0, atol=1e-12)
    assert abs(x[0, 5, 1]) < 1e-12 and x[0, 5, 0] > 0
    # Distances are preserved.
    w = inter.key_joints()
    np.testing.assert_allclose(np.linalg.norm(x[:, 2] - x[:, 7], axis=-1), np.linalg.norm(w[:, 0, 2] - w[:, 1, 2], axis=-1))
    assert np.isfinite(canonical_joints(_instance(rng, with_object=True))[:, OBJECT]).all()


def test_interval_features(rng: np.random.Generator) -> None:
    x = rng.normal(size=(10, N_JOINTS, 3))
    f = interval_features(x, np.array([0, 3, 7]), np.array([3, 7, 10]), fps=5.0)
    np.testing.assert_array_equal(f.end, x[[2, 6, 9]])
    np.testing.assert_array_equal(f.disp, x[[2, 6, 9]] - x[[0, 2, 6]])
    np.testing.assert_allclose(f.seconds, [0.6, 0.8, 0.6])
    with pytest.raises(ModelError, match="start < stop"):
        interval_features(x, np.array([4]), np.array([4]), fps=5.0)


def test_reference_weights() -> None:
    z = np.array([1, 2, 2, 0, 0, 3, 0, 2, 0, 0, 1])
    W = reference_weights(z, other_side=False)
    np.testing.assert_allclose(W[5], LONE_REFERENCE[5])  # lone agent-1 base: agent 0's base
    assert W[5, 0] == 1.0
    np.testing.assert_allclose(W[1, [2, 7]], 0.5)  # group {1, 2, 7}: mean of the others
    np.testing.assert_allclose(W[0, OBJECT], 1.0)
    assert not W[[3, 4, 6, 8, 9]].any()
    np.testing.assert_allclose(LONE_REFERENCE[OBJECT, [0, 5]], 0.5)  # a lone object: midpoint of the bases
    Wo = reference_weights(z, other_side=True)
    np.testing.assert_allclose(Wo[1, 7], 1.0)  # same-agent mate 2 is not a reference
    np.testing.assert_allclose(Wo[7, [1, 2]], 0.5)


def _known_samples(rng: np.random.Generator, n: int):
    """End configurations whose joint-2 offset from agent 1's base has known distributions."""
    end = rng.normal(0, 0.3, (n, N_JOINTS, 3))
    end[:, 5] = rng.normal([2.0, 0.0, 1.0], 0.05, (n, 3))
    h = stats.weibull_min(3.0, scale=0.6).rvs(n, random_state=rng)
    v = stats.weibull_min(1.5, scale=0.2).rvs(n, random_state=rng)
    th = stats.vonmises(4.0, loc=2.5).rvs(n, random_state=rng)
    end[:, 2] = end[:, 5] + np.stack([h * np.cos(th), h * np.sin(th), v * rng.choice([-1, 1], n)], axis=1)
    disp = rng.normal(0, 0.1, (n, N_JOINTS, 3))
    m = stats.expon(scale=0.05).rvs(n, random_state=rng)
    vz = stats.expon(scale=0.02).rvs(n, random_state=rng)
    a = rng.uniform(-np.pi, np.pi, n)
    disp[:, 4] = np.stack([m * np.cos(a), m * np.sin(a), vz], axis=1)
    return end, disp


def test_fitted_potentials_recover_known_parameters(rng: np.random.Generator) -> None:
    end, disp = _known_samples(rng, 4000)
    z = np.zeros(N_JOINTS, np.int64)
    z[2] = 1  # joint 2 lone: relative to agent 1's base
    pot = fit_type_potentials(end, disp, z, AffordanceConfig(eps=1e-9, shape_max=50.0))
    kh, lh, kv, lv, mu, kap = pot.spatial[2]
    assert kh == pytest.approx(3.0, rel=0.05) and lh == pytest.approx(0.6, rel=0.03)
    assert kv == pytest.approx(1.5, rel=0.05) and lv == pytest.approx(0.2, rel=0.04)
    assert mu == pytest.approx(2.5, abs=0.03) and kap == pytest.approx(4.0, rel=0.06)
    k_m, mean_h, k_v, mean_v = pot.motion[4, :4]  # Null joint 4: exponentials, stored as k = 1
    assert k_m == k_v == 1.0
    assert mean_h == pytest.approx(0.05, rel=0.05) and mean_v == pytest.approx(0.02, rel=0.05)
    assert np.isnan(pot.spatial[4]).all()


def _reference_log_spatial(pot, z, end, eps, other_side):  # noqa: ANN001
    W = reference_weights(z, other_side=other_side)
    total = np.zeros(end.shape[0])
    for j in np.flatnonzero(z > 0):
        off = end[:, j] - np.nan_to_num(end).transpose(0, 2, 1) @ W[j]  # W is 0 on the absent object
        h, v, th = polar(off, eps)
        kh, lh, kv, lv, mu, kap = pot.spatial[j]
        total += stats.weibull_min(kh, scale=lh).logpdf(h) + stats.weibull_min(kv, scale=lv).logpdf(v)
        total += stats.vonmises(kap, loc=mu).logpdf(np.angle(np.exp(1j * (th - mu))) + mu)
    return total


def _reference_log_motion(pot, z, disp, eps):  # noqa: ANN001
    total = np.zeros(disp.shape[0])
    for j in np.flatnonzero(z >= 0):
        h, v, th = polar(disp[:, j], eps)
        kh, lh, kv, lv, mu, kap = pot.motion[j]
        if z[j] == 0:
            total += stats.expon(scale=lh).logpdf(h) + stats.expon(scale=lv).logpdf(v)
        else:
            total += stats.weibull_min(kh, scale=lh).logpdf(h) + stats.weibull_min(kv, scale=lv).logpdf(v)
        total += stats.vonmises(kap, loc=mu).logpdf(np.angle(np.exp(1j * (th - mu))) + mu)
    return total


def test_log_potentials_match_scipy_and_the_fit(rng: np.random.Generator) -> None:
    end, disp = _known_samples(rng, 50)
    z = np.array([1, 2, 2, 0, 0, 1, 0, 2, 3, 0, -1])
    end[:, OBJECT] = np.nan
    disp[:, OBJECT] = np.nan
    cfg = AffordanceConfig()
    pot = fit_type_potentials(end, disp, z, cfg)
    side = cfg.other_side_reference
    ls = log_spatial(pot, z, end, cfg.eps, other_side=side)
    lm = log_motion(pot, z, disp, cfg.eps)
    np.testing.assert_allclose(ls, _reference_log_spatial(pot, z, end, cfg.eps, side), rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(lm, _reference_log_motion(pot, z, disp, cfg.eps), rtol=1e-10, atol=1e-9)
    # On the training samples the potentials sum to the fitted log-likelihood.
    assert ls.sum() + lm.sum() == pytest.approx(pot.loglik, rel=1e-10)
    # Vectorized over candidates: scoring one at a time gives the same numbers.
    np.testing.assert_allclose([log_spatial(pot, z, end[i : i + 1], cfg.eps, other_side=side)[0] for i in range(5)], ls[:5], rtol=1e-12)


def test_held_out_loglik_scores_each_sample_under_the_fit_without_it(rng: np.random.Generator) -> None:
    """likelihood="held_out": Σ_n log φ(x_n | potentials fitted to the other samples)."""
    end, disp = _known_samples(rng, 8)
    z = np.array([1, 2, 2, 0, 0, 1, 0, 2, 3, 0, -1])
    end[:, OBJECT] = np.nan
    disp[:, OBJECT] = np.nan
    cfg = AffordanceConfig(likelihood="held_out")
    side = cfg.other_side_reference
    ref = 0.0
    for n in range(end.shape[0]):
        rest = np.delete(np.arange(end.shape[0]), n)
        pot = fit_type_potentials(end[rest], disp[rest], z, cfg)
        ref += log_spatial(pot, z, end[n : n + 1], cfg.eps, other_side=side)[0] + log_motion(pot, z, disp[n : n + 1], cfg.eps)[0]
    held = fit_type_potentials(end, disp, z, cfg)
    assert held.loglik == pytest.approx(ref, rel=1e-9)
    profile = fit_type_potentials(end, disp, z, AffordanceConfig())
    np.testing.assert_array_equal(held.spatial, profile.spatial)  # the parameters are the full-sample fits
    assert held.loglik < profile.loglik


def test_cartesian_vector_density_integrates_to_one_over_offsets() -> None:
    """vector_density="cartesian": the spatial potential is a density of the offset vector (m⁻³)."""
    z = np.full(N_JOINTS, -1)
    z[5] = 0
    z[2] = 1  # lone: relative to agent 1's base (joint 5)
    spatial = np.full((N_JOINTS, 6), np.nan)
    spatial[2] = (2.5, 0.5, 2.0, 0.3, 1.0, 2.0)
    pot = TypePotentials(spatial, np.full((N_JOINTS, 6), np.nan), float("nan"))
    step = 0.04
    axis = np.arange(-1.4, 1.4, step) + step / 2
    gx, gy, gz = np.meshgrid(axis, axis, axis[7:-7], indexing="ij")  # |dz| < 1.12 m
    end = np.zeros((gx.size, N_JOINTS, 3))
    end[:, 2] = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    log_dens = log_spatial(pot, z, end, 1e-9, other_side=True, cartesian=True)
    assert np.exp(log_dens).sum() * step**3 == pytest.approx(1.0, abs=5e-3)
    polar_only = log_spatial(pot, z, end, 1e-9, other_side=True)
    h = np.hypot(end[:, 2, 0], end[:, 2, 1])
    np.testing.assert_allclose(log_dens, polar_only - np.log(2.0 * h), rtol=1e-12, atol=1e-9)
