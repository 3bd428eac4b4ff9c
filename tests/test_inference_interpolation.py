"""Synthesis options of issue 4: minimum-jerk interpolation toward the planned end, body-coherent candidates."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import SynthesisConfig, synthesize
from socialaff_sim.inference.synthesis import remaining_fraction
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning import SocialAffordanceModel


def _minjerk(v: np.ndarray) -> np.ndarray:
    """Closed form written out independently: position of a rest-to-rest minimum-jerk move (Flash & Hogan)."""
    v = np.clip(v, 0.0, 1.0)
    return 10 * v**3 - 15 * v**4 + 6 * v**5


def test_remaining_fraction_from_the_anchor_is_the_minjerk_profile() -> None:
    anchor, last = 3, 13
    frames = np.arange(4, 20)
    w = remaining_fraction(frames, anchor, anchor, last)
    np.testing.assert_allclose(w, _minjerk((frames - anchor) / (last - anchor)), atol=1e-12)
    assert w[frames >= last].min() == 1.0


def test_remaining_fraction_mid_course_follows_the_same_path() -> None:
    """Re-planning at frame p with the same end reproduces the original minimum-jerk positions."""
    anchor, last, p = 0, 12, 5
    x0, x1 = np.array([0.0, 0.0, 1.0]), np.array([1.0, -0.5, 1.2])
    full = x0 + _minjerk(np.arange(13) / 12.0)[:, None] * (x1 - x0)
    frames = np.arange(p + 1, 13)
    w = remaining_fraction(frames, p, anchor, last)
    np.testing.assert_allclose(full[p] + w[:, None] * (x1 - full[p]), full[p + 1 :], atol=1e-12)


def test_config_validation() -> None:
    with pytest.raises(ConfigError, match="interpolation"):
        SynthesisConfig(interpolation="cubic")
    with pytest.raises(ConfigError, match="coherent_fraction"):
        SynthesisConfig(coherent_fraction=1.5)


@pytest.fixture(scope="module")
def fitted():
    data = generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=6))
    items = list(data)
    model = SocialAffordanceModel(learning=LearningConfig(iterations=2)).fit(items[:5], rng=np.random.default_rng(0))
    return model, items[5]


@pytest.mark.parametrize("changes", [{"interpolation": "minjerk"}, {"coherent_fraction": 1.0}])
def test_options_give_finite_deterministic_tracks(fitted, changes, seed: int) -> None:  # noqa: ANN001
    model, inter = fitted
    cfg = dataclasses.replace(SynthesisConfig(), **changes)
    obs = observed_part(inter, cfg.n_observed)
    a = synthesize(model, obs, rng=np.random.default_rng(seed), config=cfg)[0]
    b = synthesize(model, obs, rng=np.random.default_rng(seed), config=cfg)[0]
    avail = inter.key_available()
    assert np.isfinite(a[:, avail]).all()
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(
        a[: cfg.n_observed][:, avail], inter.key_joints()[: cfg.n_observed, 1][:, avail], atol=1e-9
    )


def test_coherent_candidates_keep_the_body_shape(fitted, seed: int) -> None:  # noqa: ANN001
    """With every joint of every candidate following the base, each candidate is the previous pose shifted rigidly."""
    from socialaff_sim.inference.synthesis import _AGENT1, OnlineSynthesizer

    model, inter = fitted
    cfg = SynthesisConfig(coherent_fraction=1.0)
    seen: list[np.ndarray] = []

    class Spy(OnlineSynthesizer):
        def _select(self, s, z, cand, before, static, prior):  # noqa: ANN001, ANN202
            seen.append((cand[:, _AGENT1].copy(), self._track[self._t - 1, _AGENT1].copy(), z[_AGENT1].copy()))
            return super()._select(s, z, cand, before, static, prior)

    syn = Spy(model, None, cfg)
    syn.reset(observed_part(inter, cfg.n_observed), rng=np.random.default_rng(seed))
    while not syn.done:
        syn.step()
    assert seen
    rigid_rows = 0
    for cand, prev, z in seen:
        if z[0] <= 0:
            continue
        shift = cand[:, 0] - prev[0]  # (N, 3)
        rigid = np.isclose(cand[:, 1:], prev[None, 1:] + shift[:, None], atol=1e-12).all(axis=-1)  # (N, 4)
        rigid_rows += int(rigid.all(axis=1).sum())
        # Each non-base affordable joint follows the base in about half of the candidates.
        aff = np.flatnonzero(z[1:] > 0)
        if aff.size:
            assert 0.2 < rigid[:, aff].mean() < 0.8
    assert rigid_rows > 0


def _replan_frames(model, inter, config):  # noqa: ANN001, ANN202
    """Frames at which the synthesizer planned, and the observed parse's rows when it has one."""
    from socialaff_sim.inference.synthesis import OnlineSynthesizer

    syn = OnlineSynthesizer(model, None, config)
    syn.reset(inter, rng=np.random.default_rng(4))
    plans = []
    for _ in range(inter.n_frames):
        before = syn._planned_until  # noqa: SLF001 (the state under test)
        step = syn.step()
        if syn._planned_until != before and not step.observed:  # noqa: SLF001
            plans.append(step.t)
    return plans, syn._rows  # noqa: SLF001


def test_replanning_every_delta_t_and_at_each_subevent_end(fitted) -> None:  # noqa: ANN001
    model, inter = fitted
    T0, dT = 10, 5
    paper, _ = _replan_frames(model, inter, SynthesisConfig())
    assert paper == list(range(T0, inter.n_frames, dT))  # Algorithm 2: every ΔT frames
    plans, rows = _replan_frames(model, inter, SynthesisConfig.offline())
    starts = [int(a) for a, _, _ in rows if a > T0]
    print("observed parse", rows.tolist(), "plans", plans)
    assert starts and set(starts) <= set(plans)  # a new sub-event is always planned for at its first frame
    # Between two plans: never more than ΔT frames, and never across a sub-event boundary.
    for a, b in zip(plans, plans[1:] + [inter.n_frames]):
        assert 1 <= b - a <= dT
        assert not any(a < s < b for s in starts)
    assert SynthesisConfig.reactive().replan_at_end and not SynthesisConfig().replan_at_end
