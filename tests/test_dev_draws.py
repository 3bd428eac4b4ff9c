"""scripts/_dev_draws.py: the default regression per draw of its inner folds, against the library fitted on the k-th
partition directly, and their per-instance mean."""

from __future__ import annotations

import numpy as np

from conftest import load_script

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.inference.reaction_regression import inner_folds
from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig, SwitchingRegression, Trace, instance_rows

dev_draws = load_script("_dev_draws")

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


def _config() -> SwitchingConfig:
    return SwitchingConfig(families=FAMILIES, motion=(("agent0",), ("own_velocity",), ("agent0", "gap")))


def _single(insts: list[Interaction], traces: list[Trace], seed: int, draw: int) -> SwitchingRegression:
    """The regression whose partition is the ``draw``-th the generator seeded ``seed`` gives."""
    rng = np.random.default_rng(seed)
    usable = np.arange(len(insts))  # every toy instance is longer than T0
    for _ in range(draw):
        inner_folds(insts, usable, 3, rng)
    return SwitchingRegression(_config()).fit(insts, traces, n_subevents=2, rng=rng)


def test_partition_draws_match_the_library() -> None:
    insts, traces = _toy(3)
    train, val, tr_traces, va_traces = insts[:7], insts[7:] + insts[:2], traces[:7], traces[7:] + traces[:2]
    rows = [instance_rows(i, t, T0, _config().features) for i, t in zip(val, va_traces, strict=True)]

    def score(reg: SwitchingRegression) -> list[float]:
        return [float(np.linalg.norm((reg.displacement(X, O, P) - Y).reshape(len(Y), -1, 3), axis=-1).mean())
                for X, Y, O, P in rows]

    first = score(_single(train, tr_traces, 3, 0))
    per, took = dev_draws.partition_draws(_config(), train, tr_traces, 2, 3, 3, first, score)
    singles = [score(_single(train, tr_traces, 3, k)) for k in range(3)]
    assert singles[1] != singles[0] or singles[2] != singles[0]  # the draws chose differently
    for k in (1, 2):
        assert per[f"sw:default@{k}"] == singles[k]
    assert per["sw:default@0"] == first
    np.testing.assert_allclose(per["sw:default@mean"], np.mean(singles, axis=0))
    assert "@1" in took and "@2" in took
