"""``socialaff-sim show``: print a learned model's sub-events and joint groupings, draw them."""

from __future__ import annotations

import argparse

from .validate import declare_outputs
from .help_format import HelpFormatter

__all__ = ["register", "run"]


def run(args: argparse.Namespace) -> int:
    """Load a model, print it, optionally draw it."""
    from ..learning.estimator import SocialAffordanceModel  # noqa: PLC0415
    from ..model.figures import draw_groupings, format_model  # noqa: PLC0415

    model = SocialAffordanceModel.load(args.model)
    print(format_model(model))
    if args.figure:
        print(f"wrote {draw_groupings(model, args.figure)}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``show`` sub-command."""
    p = subparsers.add_parser(
        "show",
        help="print a learned model's sub-events and joint groupings",
        description="Print what a fitted model learned: its sub-events with their durations and the joint "
        "groups of each; optionally draw the groupings.",
        epilog="example:\n  socialaff-sim show model.npz --figure groupings.png",
        formatter_class=HelpFormatter,
    )
    p.add_argument("model", metavar="MODEL.npz", help="a model written by 'socialaff-sim fit'")
    p.add_argument("--figure", metavar="PATH", help="also draw the grouping of each sub-event (PNG)")
    declare_outputs(p, figure="file")
    p.set_defaults(func=run)
