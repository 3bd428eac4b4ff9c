"""The optional compiler's switch: the setting's validation and a missing numba's error."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import compiled
from socialaff_sim.inference.synthesis_config import SynthesisConfig


def test_kernel_setting_accepts_the_two_kernels_and_names_a_wrong_one() -> None:
    assert SynthesisConfig().kernel == "numpy"
    assert SynthesisConfig(kernel="numba").kernel == "numba"
    with pytest.raises(ConfigError, match="kernel: expected"):
        SynthesisConfig(kernel="cython")


def test_available_follows_the_import_system() -> None:
    assert compiled.available() == (importlib.util.find_spec("numba") is not None)


def test_missing_numba_is_a_config_error_naming_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: False)
    with pytest.raises(ConfigError, match=r"socialaff-sim\[fast\]"):
        compiled.njit(lambda x: x)


@pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
def test_njit_compiles_a_loop_that_equals_numpy() -> None:
    def total(x: np.ndarray) -> float:
        s = 0.0
        for v in x:
            s += v
        return s

    x = np.random.default_rng(0).normal(size=257)
    fast = compiled.njit(total)
    assert fast(x) == total(x)  # the same sequential sum, the same bits
    assert fast(x) == pytest.approx(float(np.sum(x)), rel=1e-12)
