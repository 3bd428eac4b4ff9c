"""The ``socialaff-sim`` command: sub-commands registered from ``cmd_*`` modules.

Each module ``socialaff_sim.cli.cmd_<name>`` exposes ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``(args) -> int``.
This is the only place in the package that prints and exits.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType

from .. import __version__
from ..errors import SocialAffError
from .validate import check_outputs

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


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def _terminate(signum: int, frame: FrameType | None) -> None:
    # SIGTERM unwinds like Ctrl-C, so that temporary files and staging folders are removed.
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status.

    Bad input ends in one line on stderr naming the file, field or flag and what was expected,
    with exit status 2 (argparse's usage errors too); Ctrl-C or SIGTERM end with 130 after the
    outputs in progress are discarded.
    """
    # Headless machines render offscreen through EGL; a user's own choice wins.
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        os.environ["MUJOCO_GL"] = "egl"
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (2), --help and --version (0)
        return exc.code if isinstance(exc.code, int) else 2
    prog = f"socialaff-sim {args.command}"
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    try:
        check_outputs(args)
        return int(args.func(args) or 0)
    except SocialAffError as exc:
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file the command reads or writes, outside the package's own checks
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"{prog}: error: {where}{_one_line(exc.strerror or exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; outputs in progress were discarded", file=sys.stderr)
        return 130
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
