"""The command-line arguments that choose the reactor's model and recordings, shared by scripts/profile_reactor.py
and scripts/ab_reactor.py. Imports nothing of ``socialaff_sim``: ab_reactor.py chooses which tree's package to load
only after parsing them. The library never imports this module."""

from __future__ import annotations

import argparse


def add_reactor_source_arguments(p: argparse.ArgumentParser, *, seconds: float) -> None:
    """--model, --data, --interaction, --skip, --recordings and --seconds (default ``seconds``)."""
    p.add_argument("--model", required=True, help="pickle of the fitted method (scripts/bench_reactor.py --model)")
    p.add_argument("--data", default="handover:../shared/data/handover_h2h")
    p.add_argument("--interaction", default=None, help="label (default: the dataset's first)")
    p.add_argument("--skip", type=int, default=40, help="recordings of the label to skip (the model's training set)")
    p.add_argument("--recordings", type=int, default=5)
    p.add_argument("--seconds", type=float, default=seconds, help="> 0: a stream of the recordings end to end instead")
