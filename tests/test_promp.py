"""Interaction ProMP: Gaussian conditioning against the closed form, exact reproduction, the method."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.baselines.promp import (
    InteractionProMP,
    ProMPConfig,
    condition_gaussian,
    rbf_basis,
)
from socialaff_sim.data import KEY_JOINTS, Interaction
from socialaff_sim.errors import ModelError, NotFittedError
from socialaff_sim.evaluation import key_joint_error, observed_part


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.normal(size=(n, n))
    return a @ a.T + 0.1 * np.eye(n)


def test_conditioning_matches_the_closed_form(rng: np.random.Generator) -> None:
    mean, cov = rng.normal(size=5), _spd(rng, 5)
    h = rng.normal(size=(3, 5))
    y = rng.normal(size=3)
    noise = 0.3
    # Closed form: condition the joint Gaussian of (w, y) on y (Schur complement / Kalman gain).
    s = h @ cov @ h.T + noise * np.eye(3)
    gain = cov @ h.T @ np.linalg.inv(s)
    expected_mean = mean + gain @ (y - h @ mean)
    expected_cov = cov - gain @ h @ cov
    post_mean, post_cov = condition_gaussian(mean, cov, h, y, noise)
    np.testing.assert_allclose(post_mean, expected_mean, atol=1e-12)
    np.testing.assert_allclose(post_cov, expected_cov, atol=1e-12)
    # Observing some coordinates directly with tiny noise pins them and predicts the rest by regression.
    sel = np.eye(5)[:2]
    m2, _ = condition_gaussian(mean, cov, sel, y[:2], 1e-12)
    regression = mean[2:] + cov[2:, :2] @ np.linalg.solve(cov[:2, :2], y[:2] - mean[:2])
    np.testing.assert_allclose(m2[:2], y[:2], atol=1e-9)
    np.testing.assert_allclose(m2[2:], regression, atol=1e-8)
    with pytest.raises(ModelError, match="noise"):
        condition_gaussian(mean, cov, h, y, 0.0)


def test_rbf_basis_is_normalized_and_weights_reproduce_trajectories_in_its_span(rng: np.random.Generator) -> None:
    phi = rbf_basis(np.linspace(0, 1, 40), 8)
    assert phi.shape == (40, 8)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, atol=1e-12)
    method = InteractionProMP(ProMPConfig(n_basis=8, ridge=1e-12))
    w = rng.normal(size=(8, 3))
    np.testing.assert_allclose(method.weights(phi @ w), w.T, atol=1e-6)


def _key5_instances(rng: np.random.Generator, n: int, n_basis: int) -> list[Interaction]:
    """Key-joint-only instances whose trajectories lie in the span of the basis (phase-normalized)."""
    base0 = np.array([0.0, 0.0, 1.0])
    base1 = np.array([1.2, 0.0, 1.0])
    out = []
    for k in range(n):
        T = int(rng.integers(25, 40))
        phi = rbf_basis(np.linspace(0, 1, T), n_basis)
        motion = phi @ rng.normal(scale=0.2, size=(n_basis, 24))  # (T, 2 agents x 4 limbs x 3)
        joints = np.zeros((T, 2, 5, 3))
        joints[:, 0, 0], joints[:, 1, 0] = base0, base1  # bases fixed: the canonical frame is the world
        joints[:, :, 1:] = joints[:, :, :1] + np.array([0.3, 0.2, -0.3]) + motion.reshape(T, 2, 4, 3)
        out.append(Interaction("shake_hands", 10.0, joints, KEY_JOINTS, (f"a{k}", f"b{k}"), instance_id=f"i{k}"))
    return out


def test_noiseless_fit_reproduces_a_training_trajectory(rng: np.random.Generator) -> None:
    n_basis = 6
    train = _key5_instances(rng, 4, n_basis)
    cfg = ProMPConfig(
        n_basis=n_basis, ridge=1e-12, prior_var=1e-9, shrinkage=0.0, offset_var=0.0, rigid_offset_var=0.0,
        obs_noise=1e-5, human_noise=1e-5,
    )
    method = InteractionProMP(cfg).fit(train, rng=rng)
    for inst in train:
        pred = method.predict_key_joints(observed_part(inst, 3), n_observed=3)
        np.testing.assert_allclose(pred, inst.key_joints()[:, 1], atol=1e-4)
        full = method.predict(observed_part(inst, 3), n_observed=3, rng=rng)
        np.testing.assert_allclose(full.joints, inst.joints[:, 1], atol=1e-4)  # key5: the skeleton is the key joints


def test_promp_on_two_person_data_uses_only_the_observed_part(rng: np.random.Generator) -> None:
    from test_evaluation import toy_dataset

    data = toy_dataset(seed=5, labels=("hand_over",), n_pairs=3, per_pair=4)
    train, test = data.interactions[:9], data.interactions[9:]
    method = InteractionProMP()
    with pytest.raises(NotFittedError):
        method.predict(observed_part(test[0], 10), n_observed=10, rng=rng)
    method.fit(train, rng=rng)
    assert method.has_object_ and method.mean_.shape == (33 * method.config.n_basis,)
    inst = test[0]
    pred = method.predict(observed_part(inst, 10), n_observed=10, rng=rng)
    np.testing.assert_allclose(pred.joints[:10], inst.joints[:10, 1], atol=1e-12)
    assert np.isfinite(pred.joints).all() and pred.subevents is None
    shifted = inst.joints.copy()
    shifted[10:, 1] += 0.5
    again = method.predict(observed_part(inst.replace(joints=shifted), 10), n_observed=10, rng=rng)
    np.testing.assert_allclose(again.joints, pred.joints, atol=0)
    errs = [key_joint_error(method.predict(observed_part(i, 10), n_observed=10, rng=rng), i) for i in test]
    print(f"promp key-joint error {np.mean(errs):.3f} m")
    assert np.mean(errs) < 0.06


def test_offset_prior_shifts_whole_trajectories(rng: np.random.Generator) -> None:
    n_basis = 5
    train = _key5_instances(rng, 3, n_basis)
    method = InteractionProMP(ProMPConfig(n_basis=n_basis, prior_var=1e-6, shrinkage=0.0, offset_var=0.04, rigid_offset_var=0.01))
    method.fit(train, rng=rng)
    extra = method._offset_covariance(method.mean_.size // n_basis)
    k = n_basis
    # One DoF's N weights share its offset (0.04) plus its agent-axis shift (0.01).
    np.testing.assert_allclose(extra[:k, :k], 0.05, atol=1e-15)
    # Agent 0's x coordinates of two key joints share the rigid shift only; agents never share one.
    np.testing.assert_allclose(extra[0, 3 * k], 0.01, atol=1e-15)
    np.testing.assert_allclose(extra[0, 1 * k], 0.0, atol=1e-15)
    n_dof0 = method.n_dof_agent0_
    np.testing.assert_allclose(extra[:n_dof0 * k, n_dof0 * k:], 0.0, atol=1e-15)
    # A constant offset seen in agent 1's prefix carries over to its whole predicted trajectory.
    inst = train[0]
    moved = inst.joints.copy()
    moved[:, 1, 2] += np.array([0.0, 0.0, 0.1])  # the right wrist 10 cm higher throughout
    shifted = inst.replace(joints=moved)
    before = method.predict_key_joints(observed_part(inst, 8), n_observed=8)
    after = method.predict_key_joints(observed_part(shifted, 8), n_observed=8)
    lift = after[8:, 2, 2] - before[8:, 2, 2]
    assert lift.min() > 0.05, lift
