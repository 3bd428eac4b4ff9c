"""Argument checks shared by every sub-command: number types, data-loading options, output paths.

Each sub-command declares its outputs with :func:`declare_outputs`; :func:`check_outputs` runs
them all before the command starts working, so that ``fit --out`` pointing at a folder, a file
where a folder is expected or an unwritable place is reported in one line before minutes of work.
Number flags use :func:`int_range` (an ``argparse`` type: a bad value is a usage error, exit 2).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from .._atomic import check_output_file, check_output_folder
from ..data.checks import UNITS
from ..data.policy import DEFAULT_POLICY
from ..errors import OutputError

__all__ = [
    "MAX_SUBEVENTS", "PHYSICS_CHOICES", "int_range", "non_negative_int", "positive_int", "add_data_options",
    "add_physics_option", "declare_outputs", "check_outputs",
]

MAX_SUBEVENTS = 12
"""Largest |S| the command line accepts: the initial parse's dynamic programme keeps a table over
the 2^|S| sets of used sub-event types (|S| = 12: 4096 sets); the interactions use 3 to 5."""


def int_range(lo: int, hi: int | None = None) -> Callable[[str], int]:
    """An ``argparse`` type: an integer in [lo, hi] (no upper bound with ``hi=None``)."""
    want = f"an integer >= {lo}" if hi is None else f"an integer from {lo} to {hi}"

    def parse(text: str) -> int:
        try:
            value = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}, found {text!r}") from None
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"expected {want}, found {value}")
        return value

    parse.__name__ = want  # argparse names the type in its messages
    return parse


non_negative_int = int_range(0)
"""Seeds: n ≥ 0."""
positive_int = int_range(1)
"""Counts: iterations, folds, workers."""


def add_data_options(parser: argparse.ArgumentParser) -> None:
    """``--strict`` / ``--lenient`` (what a folder's unknown or bad files do) and ``--units``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--strict", dest="policy", action="store_const", const="strict", default=DEFAULT_POLICY,
                       help="stop at the first unknown, empty or invalid file of a data folder")
    group.add_argument("--lenient", dest="policy", action="store_const", const="lenient",
                       help="skip such files with one warning listing them (default)")
    parser.add_argument("--units", choices=tuple(UNITS), default="m",
                        help="length unit of npz: data files (default m); the other formats have their own")


PHYSICS_CHOICES = ("harness", "standing")
"""``--physics``'s choices: :data:`socialaff_sim.sim.sim_config.PHYSICS_MODES`, written out so that parsing the
command line does not import the simulator (a test keeps the two equal)."""


def add_physics_option(parser: argparse.ArgumentParser) -> None:
    """``--physics harness|standing``: the simulator's physics mode (``SimConfig.mode``); absent: the robot's own."""
    parser.add_argument("--physics", choices=PHYSICS_CHOICES, default=None,
                        help="physics mode: harness (position servos, the robot hanging from a compliant harness) or "
                             "standing (a balance controller stands it on its own feet while they are planted; "
                             "docs/design.md §5); default: the robot's own, its mapping's 'physics' key "
                             "(docs/robots.md)")


def declare_outputs(parser: argparse.ArgumentParser, **outputs: str) -> None:
    """Record the parser's output arguments: ``dest="folder"`` or ``dest="file"``."""
    parser.set_defaults(_outputs=outputs)


def check_outputs(args: argparse.Namespace) -> None:
    """Check every declared output before any work; the error names the flag."""
    for dest, kind in getattr(args, "_outputs", {}).items():
        value = getattr(args, dest, None)
        if value is None:
            continue
        flag = "--" + dest.replace("_", "-")
        try:
            (check_output_folder if kind == "folder" else check_output_file)(value)
        except OutputError as exc:
            raise OutputError(f"{flag}: {exc}") from None
