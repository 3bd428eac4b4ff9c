"""The switching regression's repeated inner folds (``SwitchingConfig.inner_repeats``, ``inner_average``): the
averaged blend against the R single-partition regressions fitted one by one, the averaged errors against the
single partitions' errors, and one partition unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference.reaction_regression import HOLD, inner_folds, select
from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig, SwitchingRegression, Trace, instance_rows

T0 = 10
FAMILIES = PRIMITIVE_FAMILIES[:2]  # motion and plan: enough to blend, cheap


def _toy(seed: int, n: int = 9, T: int = 24) -> tuple[list[Interaction], list[Trace]]:
    """Agent 0 wanders; agent 1 follows a noisy mix of agent 0's displacement and a noisy plan, so that the inner
    CV's choice depends on how the few instances fall into folds (four actor pairs)."""
    rng = np.random.default_rng(seed)
    body = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
    insts, traces = [], []
    for k in range(n):
        a0 = body[None] + rng.normal(0, 0.03, size=(T, 5, 3)).cumsum(0)
        a1 = np.repeat((body + [1.5, 0, 0])[None], T, 0)
        gain = rng.uniform(-0.5, 1.5)  # each instance reacts differently: a small, noisy class
        a1[T0:] = a1[T0 - 1] + gain * (a0[T0:] - a0[T0 - 1]) + rng.normal(0, 0.02, size=(T - T0, 5, 3))
        plan = a1 + rng.normal(0, 0.05, size=(T, 5, 3)).cumsum(0) * (np.arange(T) >= T0)[:, None, None]
        insts.append(Interaction(label="toy", fps=10.0, joints=np.stack([a0, a1], 1), joint_names=KEY_JOINTS,
                                 actors=(f"p{k % 4}", f"q{k % 4}"), instance_id=f"toy{k}"))
        traces.append(Trace(belief=np.full((T, 2), 0.5), phase=np.linspace(0, 1, T), plan=plan, skeleton=plan))
    return insts, traces


def _config(**kw: object) -> SwitchingConfig:
    return SwitchingConfig(families=FAMILIES, motion=(("agent0",), ("own_velocity",), ("agent0", "gap")), **kw)


def _single(insts: list[Interaction], traces: list[Trace], seed: int, draw: int) -> SwitchingRegression:
    """The one-partition regression whose partition is the ``draw``-th the generator seeded ``seed`` gives."""
    rng = np.random.default_rng(seed)
    usable = np.arange(len(insts))  # every toy instance is longer than T0
    for _ in range(draw):
        inner_folds(insts, usable, 3, rng)
    return SwitchingRegression(_config()).fit(insts, traces, n_subevents=2, rng=rng)


def _displacements(reg: SwitchingRegression, insts: list[Interaction], traces: list[Trace]) -> np.ndarray:
    parts = [instance_rows(i, t, T0, reg.config.features) for i, t in zip(insts, traces, strict=True)]
    return np.concatenate([reg.displacement(X, O, P) for X, _, O, P in parts])


@pytest.mark.parametrize("seed", [3, 11])
def test_averaged_blends_are_the_mean_of_the_single_partitions(seed: int) -> None:
    """``inner_average="blends"``: the prediction is the mean of the R regressions each fitted on one partition
    (the k-th draw of the same generator), refitted one by one here."""
    insts, traces = _toy(seed)
    R = 4
    singles = [_displacements(_single(insts, traces, seed, k), insts, traces) for k in range(R)]
    assert max(np.abs(s - singles[0]).max() for s in singles) > 1e-3  # the partitions chose differently
    bag = SwitchingRegression(_config(inner_repeats=R, inner_average="blends")).fit(
        insts, traces, n_subevents=2, rng=np.random.default_rng(seed))
    np.testing.assert_allclose(_displacements(bag, insts, traces), np.mean(singles, axis=0), atol=1e-12)
    assert len({(m.family, m.groups, m.penalty) for m in bag.members_}) == len(bag.members_)  # merged duplicates
    assert sum(m.weight for m in bag.members_) == pytest.approx(
        np.mean([sum(m.weight for m in _single(insts, traces, seed, k).members_) for k in range(R)]))


@pytest.mark.parametrize("seed", [3, 11])
def test_averaged_errors_select_on_the_mean_over_the_partitions(seed: int) -> None:
    """``inner_average="errors"``: each candidate's error is the mean of its R single-partition errors, and each
    family's member is the selection on those means (not the first partition's)."""
    insts, traces = _toy(seed)
    R = 4
    singles = [_single(insts, traces, seed, k) for k in range(R)]
    rep = SwitchingRegression(_config(inner_repeats=R, inner_average="errors")).fit(
        insts, traces, n_subevents=2, rng=np.random.default_rng(seed))
    assert set(rep.cv_errors_) == set(singles[0].cv_errors_)
    for key, value in rep.cv_errors_.items():
        assert value == pytest.approx(np.mean([s.cv_errors_[key] for s in singles]), abs=1e-12)
    cfg = rep.config
    chosen = {(m.groups, m.penalty) for m in rep.members_}
    for family, _ in cfg.families:
        cands = set(cfg.candidates(family))
        best = select({k: v for k, v in rep.cv_errors_.items() if k[0] in cands and k[0] != HOLD})
        assert best in chosen or all(m.family != family for m in rep.members_)
    firsts = {(m.groups, m.penalty) for m in singles[0].members_}
    means = {k: np.mean([s.cv_errors_[k] for s in singles]) for k in singles[0].cv_errors_}
    assert means != singles[0].cv_errors_ and (chosen != firsts or rep.blend_error_ != singles[0].blend_error_)


def test_one_partition_is_the_regression_of_before() -> None:
    insts, traces = _toy(5)
    for average in ("errors", "blends"):
        a = SwitchingRegression(_config(inner_average=average)).fit(insts, traces, n_subevents=2, rng=np.random.default_rng(1))
        b = SwitchingRegression(_config()).fit(insts, traces, n_subevents=2, rng=np.random.default_rng(1))
        assert [(m.family, m.groups, m.penalty, m.weight) for m in a.members_] == \
            [(m.family, m.groups, m.penalty, m.weight) for m in b.members_]
        np.testing.assert_array_equal(_displacements(a, insts, traces), _displacements(b, insts, traces))


def test_repeat_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="inner_repeats"):
        SwitchingConfig(inner_repeats=0)
    with pytest.raises(ConfigError, match="inner_repeats"):
        SwitchingConfig(inner_repeats=True)
    with pytest.raises(ConfigError, match="inner_average"):
        SwitchingConfig(inner_average="median")
