"""The command line: ``kalmanfield <command>`` (or ``python -m kalmanfield <command>``).

Commands: ``demo``, ``simulate``, ``identify``, ``denoise``, ``track``, ``experiment``; each has
``--help``. Exit codes: 0 done, 1 bad input (a file that is missing or does not decode, data
the library refuses), 2 a bad command line, 3 an optional dependency missing (the message
names the extra to install), 130 interrupted. The guide page :doc:`/guide/cli` shows each
command.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .. import __version__
from . import demo, denoise, experiment, identify, simulate, track
from ._common import run_safely

#: the command modules, in the order of ``--help``; each has ``register(subparsers)``
COMMANDS = (demo, simulate, identify, denoise, track, experiment)


def parser() -> argparse.ArgumentParser:
    """The argument parser of every command."""
    top = argparse.ArgumentParser(
        prog="kalmanfield",
        description="Markov random fields and Kalman recursions for images and image "
        "sequences: simulate, identify, denoise, track, and run the sources' experiments.",
        epilog="exit codes: 0 done, 1 bad input file or data, 2 bad command line, "
        "3 optional dependency missing",
    )
    top.add_argument("--version", action="version", version=f"kalmanfield {__version__}")
    commands = top.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMANDS:
        module.register(commands)
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line `argv` (default ``sys.argv[1:]``) and returns its exit code."""
    args = parser().parse_args(argv)
    return run_safely(args.run, args, sys.stderr)
