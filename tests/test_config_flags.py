"""scripts/_config_flags.py: the FIELD=VALUE settings of bench_support.py's and bench_demo_modes.py's config flags;
a field that does not exist (or was removed) is a one-line error naming the flag, exit 2."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import pytest
from conftest import load_script

from socialaff_sim.errors import ConfigError
from socialaff_sim.inference.synthesis_config import SynthesisConfig
from socialaff_sim.retarget.contact_completion import ContactCompletionConfig
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.sim_config import SimConfig
from socialaff_sim.sim.stance import StanceConfig

flags = load_script("_config_flags")


def _error(capsys: pytest.CaptureFixture[str], call) -> str:  # noqa: ANN001
    """The one stderr line of ``call()``'s exit 2."""
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        call()
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("usage:") and [line for line in err if "error:" in line] == err[-1:]
    return err[-1]  # argparse's usage, then the one error line


def test_settings_are_python_literals_of_the_classes_fields() -> None:
    p = argparse.ArgumentParser()
    got = flags.field_settings(p, "--balance", BalanceConfig, ["hand_yield=0.5", "solver='qp'", "self_clearance=None",
                                                                "com_reference='middle'"])  # a value that stays
    assert got == {"hand_yield": 0.5, "solver": "qp", "self_clearance": None, "com_reference": "middle"}
    assert dataclasses.replace(BalanceConfig(), **got).solver == "qp"
    assert flags.field_settings(p, "--foot-lock", FootLockConfig, []) == {}
    sim = flags.field_settings(p, "--sim", SimConfig, ["hand_force=40.0", "grip=False"])
    assert sim == {"hand_force": 40.0, "grip": False}
    assert dataclasses.replace(SimConfig.standing(), **sim).hand_force == 40.0


@pytest.mark.parametrize(("cls", "item", "removed"), [
    (BalanceConfig, "hand_weight=100.0", "61e3f3e"), (BalanceConfig, "release_reach=1.0", "61e3f3e"),
    (FootLockConfig, "catch_up=0.05", "61e3f3e"), (StanceConfig, "approach_near=0.3", "1d1621b"),
    (FootLockConfig, "plant_physical=True", "e1cb74d"), (BalanceConfig, "yaw_ratio=0.02", "e4dd195"),
    (SimConfig, "noslip_iterations=10", "e4dd195"), (ContactCompletionConfig, "reach=1.1x", None),
    (BalanceConfig, "com_glide=0.5", "7c7e7ae"), (BalanceConfig, "torque_handover=0.4", "7c7e7ae"),
    (BalanceConfig, "release_speed=0.1", "7c7e7ae"), (FootLockConfig, "touchdown=0.05", "7c7e7ae"),
    (FootLockConfig, "pace=1.5", "cce7ce7"), (FootLockConfig, "pace_height=0.08", "cce7ce7"),
    (FootLockConfig, "pace_base=True", "cce7ce7"), (ContactCompletionConfig, "planned_shoulder=True", "cce7ce7"),
    (BalanceConfig, "com_reference='world'", "e923256"), (BalanceConfig, "com_reference='approach'", "e923256"),
    (BalanceConfig, "shift_strike=0.3", "7eedbfc"), (ContactCompletionConfig, "base_approach=0.1", "d8e4b73"),
    (ContactCompletionConfig, "base_approach_ramp=0.0", "d8e4b73"),
    (BalanceConfig, "touch_gap=0.001", "b830275"), (BalanceConfig, "cop_kern=0.5", "7ad41ee"),
    (BalanceConfig, "no_such_field=1", None), (FootLockConfig, "hold_lift", None)])
def test_an_unknown_or_removed_field_is_exit_2(cls, item, removed, capsys) -> None:  # noqa: ANN001
    line = _error(capsys, lambda: flags.field_settings(argparse.ArgumentParser(), "--x", cls, [item]))
    assert f"--x {item!r}" in line
    assert (f"removed at {removed}" in line) if removed else ("removed" not in line)


def test_a_value_that_is_not_a_literal_is_exit_2(capsys) -> None:  # noqa: ANN001
    line = _error(capsys, lambda: flags.field_settings(argparse.ArgumentParser(), "--foot-lock", FootLockConfig,
                                                       ["lift=four"]))
    assert "--foot-lock 'lift=four'" in line and "literal" in line


def test_the_removed_table_names_no_field_that_exists() -> None:
    classes = {c.__name__: c for c in (BalanceConfig, FootLockConfig, StanceConfig, SynthesisConfig, SimConfig,
                                       ContactCompletionConfig)}
    assert set(flags.REMOVED) == set(classes)
    for name, removed in flags.REMOVED.items():
        assert removed and not set(removed) & {f.name for f in dataclasses.fields(classes[name])}
    for name, fields in flags.REMOVED_VALUES.items():  # fields that stay, values they refuse
        for field, values in fields.items():
            assert values and field in {f.name for f in dataclasses.fields(classes[name])}
            for value in values:
                with pytest.raises(ConfigError, match=field):
                    classes[name](**{field: value})


@pytest.mark.parametrize(("flag", "value", "expected"), [
    ("--foot-lock", "catch_up=0.05", "61e3f3e"),
    ("--sim", "noslip_iterations=10", "SimConfig.noslip_iterations was removed at e4dd195"),
    ("--completion", "planned_shoulder=True", "ContactCompletionConfig.planned_shoulder was removed at cce7ce7"),
    ("--balance", 'com_reference="world"', "BalanceConfig.com_reference='world' was removed at e923256"),
])
def test_bench_support_stops_on_a_removed_field_before_any_episode(tmp_path: Path, monkeypatch, capsys,  # noqa: ANN001
                                                                    flag: str, value: str, expected: str) -> None:
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "scripts"))
    bench = load_script("bench_support")
    out = tmp_path / "out.json"
    monkeypatch.setattr("sys.argv", ["bench_support.py", "--modes", "standing", "--json", str(out), flag, value])
    line = _error(capsys, bench.main)
    assert f"{flag} '{value}'" in line and expected in line
    assert not out.exists()


def test_bench_support_models_one_for_all_or_one_per_interaction(monkeypatch, capsys) -> None:  # noqa: ANN001
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "scripts"))
    bench = load_script("bench_support")
    p = argparse.ArgumentParser()
    assert bench._models(p, None) is None
    assert bench._models(p, ["m.npz"]) == {"": "m.npz"}
    assert bench._models(p, ["high_five=a.npz", "pull_up=b=c.npz"]) == {"high_five": "a.npz", "pull_up": "b=c.npz"}
    line = _error(capsys, lambda: bench._models(p, ["high_five=a.npz", "b.npz"]))
    assert "--model" in line and "'b.npz'" in line
