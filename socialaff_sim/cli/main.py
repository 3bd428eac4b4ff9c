"""The ``socialaff-sim`` command: sub-commands registered from ``cmd_*`` modules.

Each module ``socialaff_sim.cli.cmd_<name>`` exposes ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``(args) -> int``.
This is the only place in the package that prints and exits.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType

from .. import GL_CHOICE, __version__
from ..errors import SocialAffError
from .validate import check_outputs

from .help_format import HelpFormatter

__all__ = ["main", "build_parser"]

_COMMAND_MODULES = ("data", "fit", "show", "synthesize", "evaluate", "simulate", "demo")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available sub-command."""
    parser = argparse.ArgumentParser(
        prog="socialaff-sim",
        description="Learn social affordance from two-person recordings and make a MuJoCo humanoid react.",
        epilog="start with:\n  socialaff-sim demo --out demo_out      # then open demo_out/report.html\n"
        "each command's own --help gives an example",
        formatter_class=HelpFormatter,
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
    for command in sub.choices.values():
        _add_output_flags(command)
    return parser


def _add_output_flags(parser: argparse.ArgumentParser) -> None:
    """``--quiet`` and ``--verbose`` on every sub-command (a sub-command may define its own)."""
    for flags, help_text in (
        (("-q", "--quiet"), "no progress lines on stderr (results are still printed)"),
        (("-v", "--verbose"), "also log the library's details on stderr (rendering backend, MCMC iterations, …)"),
    ):
        try:
            parser.add_argument(*flags, action="store_true", help=help_text)
        except argparse.ArgumentError:
            continue  # already defined by the sub-command
    for action in parser._actions:  # nested sub-commands (``data synth``) get them too
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _add_output_flags(child)


def _configure_logging(args: argparse.Namespace) -> None:
    """The library logs; the CLI shows warnings, and with ``--verbose`` the package's INFO messages too."""
    verbose = bool(getattr(args, "verbose", False)) and not getattr(args, "quiet", False)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    if verbose:  # our details only; other libraries keep to warnings
        logging.getLogger("socialaff_sim").setLevel(logging.INFO)
        logging.getLogger("socialaff_sim").info("rendering: %s", GL_CHOICE.reason)


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
    # Importing the package chose MuJoCo's GL backend already (socialaff_sim._headless): EGL without a display.
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (2), --help and --version (0)
        return exc.code if isinstance(exc.code, int) else 2
    prog = f"socialaff-sim {args.command}"
    package_log = logging.getLogger("socialaff_sim")
    level = package_log.level
    _configure_logging(args)
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
        package_log.setLevel(level)  # main() called from Python leaves the caller's logging as it was
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
