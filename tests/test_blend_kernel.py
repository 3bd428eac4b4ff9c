"""The switching regression's compiled blend (kernel="numba", inference/blend_kernel.py): one row's displacement
against SwitchingRegression.displacement (the NumPy code it replaces) within 1e-12 relative, with every prior, with and
without clipping, rows beyond the training range, a member without regression columns, and no member (hold); a refit
repacks; a missing prior and a missing numba are errors."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.inference import blend_kernel, compiled
from socialaff_sim.inference.blend_kernel import Blend
from socialaff_sim.inference.switching import Member, SwitchingConfig, SwitchingRegression

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
F, O = 40, 12


def _regression(rng: np.random.Generator, clip: bool, members: list[tuple[tuple[str, ...], int]]) -> SwitchingRegression:
    """A regression with the learned attributes set directly: members (groups, number of columns), random weights."""
    reg = SwitchingRegression(SwitchingConfig(clip_features=clip))
    reg.scale_ = rng.uniform(0.5, 2.0, F)
    reg.lower_ = rng.uniform(-1.0, -0.2, F)
    reg.upper_ = rng.uniform(0.2, 1.0, F)
    reg.n_outputs_ = O
    alphas = rng.dirichlet(np.ones(len(members))) if members else []
    reg.members_ = [Member("f", groups, 1.0, float(a), np.sort(rng.choice(F, k, replace=False)).astype(np.int64),
                           rng.normal(size=(k, O))) for (groups, k), a in zip(members, alphas, strict=True)]
    return reg


@needs_numba
@pytest.mark.parametrize("clip", [True, False])
def test_compiled_blend_equals_numpys(rng: np.random.Generator, clip: bool) -> None:
    cases = [
        [(("agent0_velocity", "gap"), 7), (("from_plan", "plan"), 5), (("from_primitive", "primitive"), 9)],
        [(("from_plan",), 0), (("gap",), 3)],  # a member without regression columns: its prior alone
        [],  # hold
    ]
    for members in cases:
        reg = _regression(rng, clip, members)
        blend = Blend(reg)
        for _ in range(20):
            row = rng.normal(0, 1.5, (1, F))  # beyond the clip range in places
            offset, prim = rng.normal(size=(1, O)), rng.normal(size=(1, O))
            ref = reg.displacement(row, offset, prim)
            got = blend.displacement(row, offset, prim)
            assert got.shape == ref.shape == (1, O)
            assert np.allclose(got, ref, rtol=1e-12, atol=1e-14)
    # A refit replaces the members: the kernel's packed copy is made again.
    reg = _regression(rng, True, cases[0])
    blend = Blend(reg)
    row, offset = rng.normal(size=(1, F)), rng.normal(size=(1, O))
    blend.displacement(row, offset, offset)
    reg.members_ = _regression(rng, True, cases[1]).members_
    assert np.allclose(blend.displacement(row, offset, offset), reg.displacement(row, offset, offset), rtol=1e-12, atol=1e-14)
    with pytest.raises(ModelError, match="from_plan"):
        blend.displacement(row, None, offset)
    assert len(blend_kernel._kernel().signatures) == 1


def test_compiled_blend_without_numba_is_a_config_error(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: False)
    monkeypatch.setattr(compiled, "_ONCE", {})  # as in a new process: nothing compiled yet
    with pytest.raises(ConfigError, match=r"socialaff-sim\[fast\]"):
        Blend(_regression(rng, True, []))
