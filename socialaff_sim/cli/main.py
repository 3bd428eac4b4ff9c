"""The ``socialaff-sim`` command: sub-commands registered from ``cmd_*`` modules.

Each module ``socialaff_sim.cli.cmd_<name>`` exposes ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``(args) -> int``.
This is the only place in the package that prints and exits.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from .. import GL_CHOICE, __version__
from ..errors import SocialAffError

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


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    # Importing the package chose MuJoCo's GL backend already (socialaff_sim._headless): EGL without a display.
    parser = build_parser()
    args = parser.parse_args(argv)
    package_log = logging.getLogger("socialaff_sim")
    level = package_log.level
    _configure_logging(args)
    try:
        return int(args.func(args) or 0)
    except SocialAffError as exc:
        print(f"socialaff-sim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    finally:
        package_log.setLevel(level)  # main() called from Python leaves the caller's logging as it was


if __name__ == "__main__":
    sys.exit(main())
