"""The ``socialaff-sim`` command: sub-commands registered from ``cmd_*`` modules.

Each module ``socialaff_sim.cli.cmd_<name>`` exposes ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``(args) -> int``.
This is the only place in the package that prints and exits.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from .. import __version__
from ..errors import SocialAffError

__all__ = ["main", "build_parser"]

_COMMAND_MODULES = ("data", "fit", "show", "synthesize", "evaluate", "simulate", "demo")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available sub-command."""
    parser = argparse.ArgumentParser(
        prog="socialaff-sim",
        description="Learn social affordance from two-person recordings and make a MuJoCo humanoid react.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in _COMMAND_MODULES:
        try:
            module = importlib.import_module(f"{__package__}.cmd_{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"{__package__}.cmd_{name}":
                continue  # not part of this build
            raise
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    # Headless machines render offscreen through EGL; a user's own choice wins.
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        os.environ["MUJOCO_GL"] = "egl"
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SocialAffError as exc:
        print(f"socialaff-sim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
