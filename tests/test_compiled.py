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


def test_once_builds_and_warms_at_the_first_call_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: True)  # the helper's bookkeeping, numba or not
    monkeypatch.setattr(compiled, "_ONCE", {})
    built: list[dict] = []
    warmed: list[dict] = []

    def build() -> dict:
        built.append({"kernel": len(built)})
        return built[-1]

    first = compiled.once("test.a", build, warmed.append)
    again = compiled.once("test.a", build, warmed.append)
    assert first is again is built[0]
    assert len(built) == 1 and warmed == [first]  # built once, warmed once, with what was built
    other = compiled.once("test.b", build)  # another name is another build; no warm-up asked
    assert other is built[1] and len(warmed) == 1


def test_once_without_numba_raises_requires_error_before_building(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "_ONCE", {})
    monkeypatch.setattr(compiled, "available", lambda: False)
    calls: list[str] = []
    with pytest.raises(ConfigError, match=r"^kernel='numba': numba is not installed \(pip install 'socialaff-sim\[fast\]'\); "
                                          r"use kernel='numpy'$"):
        compiled.once("test.a", lambda: calls.append("build"), lambda _: calls.append("warm"))
    assert calls == [] and compiled._ONCE == {}  # nothing built, nothing kept
    monkeypatch.setattr(compiled, "available", lambda: True)
    compiled.once("test.a", lambda: calls.append("build"), lambda _: calls.append("warm"))
    assert calls == ["build", "warm"]
    # Once built, the objects are returned without asking again (some callers ask at every frame).
    monkeypatch.setattr(compiled, "available", lambda: False)
    assert compiled.once("test.a", lambda: calls.append("build")) is None and calls == ["build", "warm"]


def test_once_keeps_nothing_when_the_warm_up_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiled, "available", lambda: True)
    monkeypatch.setattr(compiled, "_ONCE", {})
    builds: list[int] = []

    def fail(_: object) -> None:
        raise ValueError("warm-up failed")

    with pytest.raises(ValueError, match="warm-up failed"):
        compiled.once("test.a", lambda: builds.append(1) or len(builds), fail)
    assert compiled._ONCE == {}
    assert compiled.once("test.a", lambda: builds.append(1) or len(builds)) == 2  # built again, then kept
    assert compiled.once("test.a", lambda: builds.append(1) or len(builds)) == 2


@pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
def test_kernel_modules_compile_once_and_warm_up_for_their_callers_types(monkeypatch: pytest.MonkeyPatch) -> None:
    from socialaff_sim.inference import belief_kernel, blend_kernel, feature_kernel, primitive_kernel, row_density

    belief_kernel.load()
    cuts = belief_kernel.cuts
    assert hasattr(cuts, "signatures")  # compiled, in place of the Python function
    belief_kernel.load()
    assert belief_kernel.cuts is cuts is compiled._ONCE[belief_kernel.__name__]["cuts"]
    monkeypatch.setattr(compiled, "_ONCE", {})  # as in a new process (the belief, which replaces its globals, aside)
    entries = [(blend_kernel._kernel, lambda k: k), (feature_kernel.kernels, lambda k: k["feature_row"]),
               (primitive_kernel.kernels, lambda k: k["cholesky_update"])]
    for get, kernel in entries:
        first = get()
        assert len(kernel(first).signatures) == 1  # warmed up: compiled for the caller's types before any use
        assert get() is first
    # The scores' kernels are compiled at their module's import (numba's decorator): warmed up by its warm(), once.
    score_kernel = importlib.import_module("socialaff_sim.inference.score_kernel")
    warms: list[int] = []
    warm = score_kernel.warm
    monkeypatch.setattr(score_kernel, "warm", lambda: warms.append(1) or warm())
    assert row_density.compiled_kernels() is score_kernel is row_density.compiled_kernels()
    assert warms == [1]
    assert len(compiled._ONCE) == 4
