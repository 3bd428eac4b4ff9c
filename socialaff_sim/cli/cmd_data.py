"""``socialaff-sim data``: synthesize, inspect and convert datasets."""

from __future__ import annotations

import argparse
from pathlib import Path

from .._atomic import output_folder
from ..data import load_dataset, save_dataset
from ..data.summary import format_summary
from .validate import add_data_options, declare_outputs, non_negative_int

from .help_format import HelpFormatter

__all__ = ["register"]


def _synth(args: argparse.Namespace) -> int:
    from ..data.synthetic import generate_dataset

    dataset = generate_dataset(seed=args.seed)
    print(format_summary(dataset))
    if args.out:
        with output_folder(args.out) as staging:
            paths = save_dataset(dataset, staging)
        print(f"\nwrote {len(paths)} files to {args.out} (read back with: socialaff-sim data inspect npz:{args.out})")
    return 0


def _inspect(args: argparse.Namespace) -> int:
    print(format_summary(load_dataset(args.spec, policy=args.policy, units=args.units)))
    return 0


def _convert(args: argparse.Namespace) -> int:
    dataset = load_dataset(args.spec, policy=args.policy, units=args.units)
    out = Path(args.out)
    with output_folder(out) as staging:  # all files or none; a second writer is refused
        paths = save_dataset(dataset, staging)
    print(f"wrote {len(paths)} interaction files to {out}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``data`` and its sub-commands."""
    data = subparsers.add_parser(
        "data",
        help="synthesize, inspect and convert datasets",
        description="Generate the embedded synthetic dataset, inspect a dataset, or convert one to the "
        "project's npz format (docs/data_format.md).",
        epilog="examples:\n  socialaff-sim data synth --out my_recordings\n  socialaff-sim data inspect sbu:PATH\n"
        "  socialaff-sim data convert handover:PATH --out my_npz",
        formatter_class=HelpFormatter,
    )
    sub = data.add_subparsers(dest="data_command", metavar="ACTION")
    sub.required = True
    spec_help = "dataset spec: sbu:PATH, handover:PATH, nuisi:PATH, hhoi:PATH, npz:DIR or synthetic[:SEED]"

    p = sub.add_parser("synth", help="generate the embedded synthetic dataset and print its summary",
                       description="Generate the embedded synthetic dataset (five interactions, 8 actors) and "
                       "print its summary; --out also writes it as npz files.",
                       epilog="example:\n  socialaff-sim data synth --seed 1 --out my_recordings", formatter_class=HelpFormatter)
    p.add_argument("--seed", type=non_negative_int, default=0, help="generator seed (default 0)")
    p.add_argument("--out", help="also write it as npz files to this folder")
    declare_outputs(p, out="folder")
    p.set_defaults(func=_synth)

    p = sub.add_parser("inspect", help="per-class counts, lengths, fps and key-joint availability",
                       description="Print per-class counts, lengths, frame rates and key-joint availability of a dataset.",
                       epilog="example:\n  socialaff-sim data inspect npz:my_recordings", formatter_class=HelpFormatter)
    p.add_argument("spec", metavar="PATH_OR_SPEC", help=spec_help)
    add_data_options(p)
    p.set_defaults(func=_inspect)

    p = sub.add_parser("convert", help="convert a dataset to the project's npz format",
                       description="Convert a supported dataset to the project's npz format (docs/data_format.md).",
                       epilog="example:\n  socialaff-sim data convert sbu:PATH --out my_npz", formatter_class=HelpFormatter)
    p.add_argument("spec", metavar="SPEC", help=spec_help)
    p.add_argument("--out", required=True, help="output folder (one .npz per interaction)")
    add_data_options(p)
    declare_outputs(p, out="folder")
    p.set_defaults(func=_convert)
