"""``socialaff-sim demo``: the main job on the embedded synthetic dataset (no downloads)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..data.summary import format_summary

__all__ = ["register"]


def _run(args: argparse.Namespace) -> int:
    from ..data.synthetic import INTERACTIONS, generate_dataset

    dataset = generate_dataset(seed=args.seed)
    if args.interaction:
        dataset = dataset.of_label(args.interaction)
    print(format_summary(dataset))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from .._atomic import atomic_write_text

    atomic_write_text(out / "dataset_summary.txt", format_summary(dataset) + "\n")
    print(f"\nwrote {out / 'dataset_summary.txt'}  (interactions available: {', '.join(INTERACTIONS)})")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``demo``."""
    p = subparsers.add_parser("demo", help="run the main job on the embedded synthetic dataset")
    p.add_argument("--interaction", help="one interaction (default: all five)")
    p.add_argument("--out", default="demo_out", help="output folder (default: demo_out)")
    p.add_argument("--seed", type=int, default=0, help="seed of the synthetic data and of every sampler")
    p.set_defaults(func=_run)
