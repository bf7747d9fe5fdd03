"""What the commands share: exit codes, error reporting, common options."""

from __future__ import annotations

import argparse
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..io import read_image, read_stack
from ..io._optional import MissingDependency
from ..io.images import PICTURE_SUFFIXES

OK, BAD_INPUT, USAGE, MISSING_DEPENDENCY, INTERRUPTED = 0, 1, 2, 3, 130


def run_safely(run: Callable[[argparse.Namespace], int], args: argparse.Namespace, err: TextIO):
    """`run(args)`, with the errors users cause turned into a message and an exit code."""
    try:
        return run(args)
    except MissingDependency as e:
        print(f"kalmanfield {args.command}: {e}", file=err)
        return MISSING_DEPENDENCY
    except KeyboardInterrupt:
        print(f"kalmanfield {args.command}: interrupted", file=err)
        return INTERRUPTED
    except (OSError, ValueError, TypeError, MemoryError) as e:
        print(f"kalmanfield {args.command}: error: {e}", file=err)
        if getattr(args, "debug", False):
            traceback.print_exc(file=err)
        return BAD_INPUT


def common(parser: argparse.ArgumentParser, *, seed: int | None = None) -> None:
    """The options every command has, and ``--seed`` (default `seed`) where something is
    random."""
    if seed is not None:
        parser.add_argument(
            "--seed",
            type=nonnegative_int,
            default=seed,
            help=f"seed of the random numbers (default {seed}): the same seed, the same output",
        )
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--debug", action="store_true", help="print tracebacks of errors")


def _integer(text: str, low: int, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} expected, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"{what} expected, got {value}")
    return value


def positive_int(text: str) -> int:
    return _integer(text, 1, "a positive integer")


def nonnegative_int(text: str) -> int:
    return _integer(text, 0, "a non-negative integer")


def at_least(low: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        return _integer(text, low, f"an integer of at least {low}")

    parse.__name__ = f"int ≥ {low}"
    return parse


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a positive number expected, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"a positive number expected, got {text!r}")
    return value


def say(args: argparse.Namespace, *lines: Any) -> None:
    """Prints to stdout unless --quiet."""
    if not args.quiet:
        for line in lines:
            print(line)


def load_data(path: Path) -> tuple[np.ndarray, bool]:
    """An image or a stack from a file, and whether its last axis holds colour channels: a
    .npy as stored (a 3-D one is a stack, time first), a picture as decoded, anything else
    as a stack of frames (one frame: the image)."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return np.asarray(read_image(path) if path.is_file() else read_stack(path)), False
    if suffix in PICTURE_SUFFIXES:
        image = read_image(path)
        return image[..., :3] if image.ndim == 3 else image, image.ndim == 3
    stack = read_stack(path)
    colour = stack.ndim == 4
    if colour:
        stack = stack[..., :3]
    return (stack[0] if len(stack) == 1 else stack), colour
