"""The switching regression's ``primitive`` family: the interaction primitive's conditioning against a dense
joint-Gaussian reference, its causal predictions against the ``promp`` baseline's protocol run, the family's
selection, the out-of-fold rule of its training predictions, contiguous inner folds, and the method end to end."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

import socialaff_sim.inference.methods as methods_module
from socialaff_sim.baselines.promp import InteractionProMP
from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.evaluation.registry import get_method
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig, rbf_basis
from socialaff_sim.inference.methods import AffordanceMethod
from socialaff_sim.inference.reaction_regression import inner_folds
from socialaff_sim.inference.switching import (
    FAMILIES, PRIMITIVE_FAMILIES, SwitchingConfig, SwitchingRegression, Trace, instance_rows,
)
from socialaff_sim.learning.config import LearningConfig

T0 = 10


def _instances(rng: np.random.Generator, n: int, actors: int = 4) -> list[Interaction]:
    """Key-joint instances of varying length: agent 0 reaches out along a phase-normalized curve, agent 1 mirrors it
    with an instance-specific amplitude (so the primitive's conditioning has something to infer)."""
    out = []
    for k in range(n):
        T = int(rng.integers(24, 34))
        s = np.linspace(0, 1, T)
        amp = rng.uniform(0.2, 0.5)
        body0 = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
        body1 = body0 * [-1, -1, 1] + [1.4, 0, 0]
        a0 = np.repeat(body0[None], T, 0)
        a1 = np.repeat(body1[None], T, 0)
        bump = np.sin(np.pi * s) * amp
        a0[:, 1, 0] += bump
        a1[:, 2, 0] -= bump + rng.normal(0, 0.005, T)
        a0 += rng.normal(0, 0.005, size=a0.shape)
        out.append(Interaction("reach", 10.0, np.stack([a0, a1], 1), KEY_JOINTS, (f"p{k % actors}", f"q{k % actors}"),
                               instance_id=f"r{k:02d}"))
    return out


def test_primitive_conditioning_matches_a_dense_joint_gaussian(rng: np.random.Generator) -> None:
    """predict_key_joints (information form, per-DoF statistics) against the covariance form on an explicit
    observation matrix: mean + C Hᵀ (H C Hᵀ + R)⁻¹ (y − H mean), solved by scipy."""
    insts = _instances(rng, 8)
    prim = InteractionPrimitive(ProMPConfig(n_basis=6)).fit(insts[1:])
    inst, visible, duration = insts[0], 18, 30
    got = prim.predict_key_joints(inst, n_observed=T0, duration=duration, visible=visible)
    y, anchor = prim._trajectories(inst)
    n, T, d0, D = 6, inst.n_frames, prim.n_dof_agent0_, y.shape[1]
    phi = rbf_basis(np.minimum(np.arange(T) / (duration - 1), 1.0), n)
    rows, obs, noise = [], [], []
    for d in range(D):
        frames = range(visible) if d < d0 else range(T0)
        for t in frames:
            h = np.zeros(D * n)
            h[d * n:(d + 1) * n] = phi[t]
            rows.append(h)
            obs.append(y[t, d])
            noise.append(0.1**2 if d < d0 else 0.01**2)
    H, R = np.array(rows), np.diag(noise)
    C, m = prim.cov_, prim.mean_
    post = m + C @ H.T @ linalg.solve(H @ C @ H.T + R, np.array(obs) - H @ m, assume_a="pos")
    ref = phi @ post.reshape(D, n)[d0:].T + np.tile(anchor, 5)
    np.testing.assert_allclose(got.reshape(T, -1), ref, atol=1e-8)


def test_causal_key_joints_are_the_promp_baselines_causal_output(rng: np.random.Generator) -> None:
    """The training rows' primitive predictions are exactly what the ``promp`` baseline outputs under the causal
    protocol (frame t from agent 0's frames ≤ t, its duration estimated on them)."""
    insts = _instances(rng, 8)
    baseline = InteractionProMP().fit(insts[1:], rng=np.random.default_rng(0))
    prim = InteractionPrimitive().fit(insts[1:])
    got = prim.causal_key_joints(insts[0], T0)
    run = run_protocol(baseline, insts[0], protocol="causal", n_observed=T0, rng=np.random.default_rng(0))
    assert np.isnan(got[:T0]).all()
    np.testing.assert_allclose(got[T0:], run.key_joints[T0:], atol=1e-12)
    # Causal: frame t does not change when agent 0's later frames do.
    moved = insts[0].replace(joints=np.where(np.arange(insts[0].n_frames)[:, None, None, None] > 15,
                                             insts[0].joints + 0.3, insts[0].joints))
    np.testing.assert_array_equal(prim.causal_key_joints(moved, T0)[T0:16], got[T0:16])
    assert not np.allclose(prim.causal_key_joints(moved, T0)[17:], got[17:])


def _toy(rng: np.random.Generator, truth: str, n: int = 12) -> tuple[list[Interaction], list[Trace]]:
    """Agent 1 follows the trace's ``primitive`` or its ``plan`` (the other one is noise)."""
    insts, traces = [], []
    for inst in _instances(rng, n):
        T = inst.n_frames
        joints = inst.joints.copy()
        after = (np.arange(T) >= T0)[:, None, None]
        walk = [joints[:, 1] + rng.normal(0, 0.15, size=(T, 5, 3)).cumsum(0) * after for _ in range(2)]
        right = walk[0]
        joints[T0:, 1] = right[T0:]
        prim, plan = (right, walk[1]) if truth == "primitive" else (walk[1], right)
        traces.append(Trace(belief=np.full((T, 2), 0.5), phase=np.linspace(0, 1, T), plan=plan, skeleton=plan,
                            primitive=prim, primitive_skeleton=prim))
        insts.append(inst.replace(joints=joints))
    return insts, traces


@pytest.mark.parametrize("truth", ["primitive", "plan"])
def test_the_family_that_predicts_is_selected(rng: np.random.Generator, truth: str) -> None:
    insts, traces = _toy(rng, truth)
    reg = SwitchingRegression(SwitchingConfig(families=PRIMITIVE_FAMILIES)).fit(insts, traces, n_subevents=2, rng=rng)
    weights = {f: sum(m.weight for m in reg.members_ if m.family == f) for f, _ in PRIMITIVE_FAMILIES}
    assert weights[truth] >= 0.9
    chosen = [m for m in reg.members_ if m.family == truth]
    assert chosen[0].prior == ("from_" + truth)
    X, Y, O, P = instance_rows(insts[0], traces[0], T0, reg.config.features)
    np.testing.assert_allclose(reg.displacement(X, O, P), Y, atol=0.03)
    if truth == "primitive":
        assert reg.uses_primitive
        with pytest.raises(ModelError, match="from_primitive"):
            reg.displacement(X, O)
        # Without the family the inner CV can only do worse.
        without = SwitchingRegression(SwitchingConfig(families=FAMILIES)).fit(insts, traces, n_subevents=2, rng=rng)
        assert without.blend_error_ > 3 * reg.blend_error_


def test_training_primitives_are_fitted_without_their_instance(monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator) -> None:
    """Each training instance's primitive prediction comes from a primitive fitted without it (cross_fit = 2), as
    its plan does; with cross_fit = 1 both are in sample."""
    seen: list[set[str]] = []

    class FakeModel:
        def __init__(self, *args: object) -> None:
            pass

        def fit(self, insts: list[Interaction], *, rng: np.random.Generator | None = None) -> FakeModel:
            self.ids = {i.instance_id for i in insts}
            seen.append(self.ids)
            return self

    def fake_trace(model: FakeModel, body: object, inst: Interaction, config: object, rng: object, *, stride: int = 1) -> Trace:
        T, own = inst.n_frames, float(inst.instance_id in model.ids)
        return Trace(belief=np.full((T, 2), own), phase=np.zeros(T), plan=np.full((T, 5, 3), own),
                     skeleton=np.full((T, 5, 3), own))

    def fake_primitive_trace(prim: FakeModel, body: object, tr: Trace, inst: Interaction, n_observed: int, *,
                             stride: int = 1) -> Trace:
        own = float(inst.instance_id in prim.ids)
        return Trace(tr.belief, tr.phase, tr.plan, tr.skeleton, np.full_like(tr.plan, own), np.full_like(tr.plan, own))

    monkeypatch.setattr(methods_module, "SocialAffordanceModel", FakeModel)
    monkeypatch.setattr(methods_module, "InteractionPrimitive", FakeModel)
    monkeypatch.setattr(methods_module, "trace", fake_trace)
    monkeypatch.setattr(methods_module, "primitive_trace", fake_primitive_trace)
    insts = _instances(rng, 8)
    m = AffordanceMethod("full")
    m.model_ = FakeModel().fit(insts)
    m.primitive_ = FakeModel().fit(insts)
    m.body_ = None
    for cfg, own in [(SwitchingConfig(families=PRIMITIVE_FAMILIES), 0.0),
                     (SwitchingConfig(families=PRIMITIVE_FAMILIES, contiguous=True), 0.0),
                     (SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1), 1.0)]:
        traces = m._training_traces(insts, cfg, rng)
        assert all(t.primitive is not None and np.all(t.primitive == own) and np.all(t.plan == own) for t in traces)
    traces = m._training_traces(insts, SwitchingConfig(families=FAMILIES), rng)  # without the family: none computed
    assert all(t.primitive is None for t in traces)


def test_contiguous_inner_folds_are_consecutive_runs_with_one_pair(rng: np.random.Generator) -> None:
    one_pair = _instances(rng, 10, actors=1)
    folds = inner_folds(one_pair, np.arange(10), 3, rng, contiguous=True)
    assert folds == [[0, 1, 2, 3], [4, 5, 6], [7, 8, 9]]
    assert inner_folds(one_pair, np.arange(10), 3, rng) != folds  # random instances without it (seeded rng)
    many = _instances(rng, 12, actors=4)
    a = inner_folds(many, np.arange(12), 3, np.random.default_rng(5), contiguous=True)
    b = inner_folds(many, np.arange(12), 3, np.random.default_rng(5))
    assert a == b  # two pairs or more: pair-disjoint either way
    with pytest.raises(ConfigError, match="priors"):
        SwitchingConfig(families=(("x", (("from_plan", "from_primitive"),)),))


def test_method_with_the_primitive_family_end_to_end_is_deterministic(shake8) -> None:  # noqa: ANN001
    data = list(shake8)
    cfg = SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1, inner_folds=2)  # in sample: one MCMC fit each

    def run(seed: int) -> np.ndarray:
        m = AffordanceMethod("full", learning=LearningConfig(iterations=1), reaction=cfg).fit(
            data[:4], rng=np.random.default_rng(seed))
        assert isinstance(m.primitive_, InteractionPrimitive)
        return run_protocol(m, data[6], protocol="causal", n_observed=T0, rng=np.random.default_rng(1)).joints

    first = run(0)
    assert np.isfinite(first[T0:]).all()
    np.testing.assert_array_equal(run(0), first)


def test_registered_option() -> None:
    m = get_method("full_noprimitive")()  # type: ignore[call-arg]
    assert isinstance(m, AffordanceMethod) and m.name == "full_noprimitive"
    assert m.reaction is not None and m.reaction.families == FAMILIES and not m.reaction.needs_primitive
    full = get_method("full")()  # type: ignore[call-arg]
    assert full.reaction is not None and full.reaction.families == PRIMITIVE_FAMILIES and full.reaction.needs_primitive
    assert SwitchingConfig().families == PRIMITIVE_FAMILIES
