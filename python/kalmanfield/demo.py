"""The main job, as in kalmanfield 0.1.0: ``python -m kalmanfield.demo [--out DIR] [--size N]
[--seed S] …`` is ``kalmanfield demo …`` (see :doc:`/guide/cli`)."""

from __future__ import annotations

from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``kalmanfield demo`` with `argv` (default ``sys.argv[1:]``)."""
    import sys

    from .cli import main as cli

    return cli(["demo", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
