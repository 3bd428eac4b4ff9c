"""scripts/_dev_synthesis.py: ``--set`` changes the default's causal synthesis, and the fit read back from its cache
leaves the method and the generator exactly as the fit itself did (so a cached run's traces are an uncached run's)."""

from __future__ import annotations

import argparse
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import load_script

from socialaff_sim.inference.methods import AffordanceMethod, trace
from socialaff_sim.inference.synthesis_config import SynthesisConfig

sys.modules.setdefault("_config_flags", load_script("_config_flags"))  # what the scripts import from scripts/
sys.modules.setdefault("_reactor_args", load_script("_reactor_args"))
dev_synthesis = load_script("_dev_synthesis")


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser()
    dev_synthesis.add_synthesis_arguments(ap)
    return ap


def test_set_changes_the_reactive_synthesis_and_names_the_cache() -> None:
    ap = _parser()
    args = ap.parse_args(["--set", "belief_step=0.4", "--set", "delta_t=10"])
    method = dev_synthesis.with_settings(AffordanceMethod.from_preset("full", "default", reaction=None), args.set, ap)
    assert method.synthesis == SynthesisConfig.reactive(belief_step=0.4, delta_t=10)
    assert dev_synthesis.settings_suffix(args.set) == "_set-belief_step-0.4_set-delta_t-10"
    assert dev_synthesis.settings_suffix([]) == ""
    plain = dev_synthesis.with_settings(AffordanceMethod.from_preset("full", "default", reaction=None), [], ap)
    assert plain.synthesis == SynthesisConfig.reactive()
    for bad in ("delta_t", "no_such_field=1", "delta_t=ten"):
        with pytest.raises(SystemExit) as e:
            dev_synthesis.with_settings(AffordanceMethod.from_preset("full", "default", reaction=None), [bad], ap)
        assert e.value.code == 2


def test_a_removed_synthesis_field_is_exit_2_naming_its_commit(capsys) -> None:  # noqa: ANN001
    ap = _parser()
    for bad, removed in (("horizon_overrun=true", "7f03f2e"), ("no_such_field=1", None)):
        with pytest.raises(SystemExit) as e:
            dev_synthesis.with_settings(AffordanceMethod.from_preset("full", "default", reaction=None), [bad], ap)
        assert e.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith(f"{ap.prog}: error: --set {bad!r}")
        assert (f"removed at {removed}" in err[-1]) if removed else ("removed" not in err[-1])


def test_cached_fit_restores_the_models_and_the_generator(shake8, tmp_path: Path) -> None:  # noqa: ANN001
    train, inst = list(shake8)[:4], shake8[6]
    syn = SynthesisConfig.reactive(delta_t=10)

    def run(path: Path | None) -> tuple[float, np.ndarray, dict]:
        method = AffordanceMethod.from_preset("full", "default", reaction=None)
        rng = np.random.default_rng(5)
        seconds = dev_synthesis.fit_cached(method, train, rng, path)
        plan = trace(method.model_, method.body_, inst, syn, rng).plan  # draws from the generator after the fit
        return seconds, plan, rng.bit_generator.state

    s0, plan0, state0 = run(None)  # no cache: the fit itself
    path = tmp_path / "fit.pkl"
    s1, plan1, state1 = run(path)  # fits and writes
    s2, plan2, state2 = run(path)  # reads
    assert np.isfinite(s0) and np.isfinite(s1) and np.isnan(s2)
    models, _, state = pickle.loads(path.read_bytes())
    assert len(models) == 1
    assert state != state0  # the state after the fit was stored, not the seed's
    np.testing.assert_array_equal(plan0, plan1)
    np.testing.assert_array_equal(plan0, plan2)
    assert state0 == state1 == state2
