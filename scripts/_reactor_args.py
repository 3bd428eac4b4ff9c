"""The command-line arguments that choose the reactor's model and recordings, and the synthesis settings changed
(``--set``), shared by scripts/profile_reactor.py and scripts/ab_reactor.py. Imports nothing of ``socialaff_sim``:
ab_reactor.py chooses which tree's package to load only after parsing them. The library never imports this module."""

from __future__ import annotations

import argparse
import dataclasses

from _config_flags import REMOVED  # scripts/ (sys.path[0]); it imports nothing of socialaff_sim either


def add_reactor_source_arguments(p: argparse.ArgumentParser, *, seconds: float) -> None:
    """--model, --data, --interaction, --skip, --recordings and --seconds (default ``seconds``)."""
    p.add_argument("--model", required=True, help="pickle of the fitted method (scripts/bench_reactor.py --model)")
    p.add_argument("--data", default="handover:../shared/data/handover_h2h")
    p.add_argument("--interaction", default=None, help="label (default: the dataset's first)")
    p.add_argument("--skip", type=int, default=40, help="recordings of the label to skip (the model's training set)")
    p.add_argument("--recordings", type=int, default=5)
    p.add_argument("--seconds", type=float, default=seconds, help="> 0: a stream of the recordings end to end instead")


def add_setting_argument(p: argparse.ArgumentParser, which: str) -> None:
    """--set FIELD=VALUE (repeatable): a field of ``which`` synthesis configuration changed."""
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help=f"a SynthesisConfig field of {which}, changed (repeatable; e.g. n_samples=50): what a setting "
                        "would cost, not a default")


def _setting(config: object, text: str) -> tuple[str, object]:
    """``FIELD=VALUE`` → (field, value of the field's current type); a ValueError naming the flag when malformed."""
    name, eq, value = text.partition("=")
    fields = {f.name for f in dataclasses.fields(config)}  # type: ignore[arg-type]
    if not eq or name not in fields:
        gone = REMOVED.get(type(config).__name__, {}).get(name)
        why = f"; {type(config).__name__}.{name} was removed at {gone}, see docs/design.md" if gone else ""
        raise ValueError(f"--set {text!r}: expected FIELD=VALUE with FIELD one of SynthesisConfig's fields{why}")
    kind = type(getattr(config, name))
    try:
        return name, (value.lower() in ("1", "true", "yes") if kind is bool else kind(value))
    except ValueError:
        raise ValueError(f"--set {text!r}: expected a {kind.__name__} value") from None


def changed_synthesis(config: object, settings: list[str], p: argparse.ArgumentParser) -> object:
    """``config`` with the ``--set`` settings applied (``dataclasses.replace``); a malformed one: ``p.error`` (exit 2)."""
    try:
        changes = dict(_setting(config, s) for s in settings)
    except ValueError as e:
        p.error(str(e))
    return dataclasses.replace(config, **changes)  # type: ignore[type-var]
