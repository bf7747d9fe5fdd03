"""The benchmark pages of the documentation: a bench script's report becomes
``docs/benchmarks/<name>.md``, headed by the date, the machine and the command of the run.

A run with ``--quick`` or with non-default options writes ``bench_out/<name>.md`` instead
(git-ignored), so that a partial run never replaces the page of a full one.
"""

from __future__ import annotations

import os
import platform
import sys
from datetime import date
from pathlib import Path

import numpy as np

import kalmanfield as kf

ROOT = Path(__file__).resolve().parent.parent
PAGES = ROOT / "docs" / "benchmarks"
SCRATCH = ROOT / "bench_out"
#: the 1-minute load average when the bench script started (None where unknown)
LOAD_AT_START = os.getloadavg()[0] if hasattr(os, "getloadavg") else None


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``), or what the platform module knows."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def memory_gib() -> float | None:
    """Physical memory in GiB (None where unknown)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError, AttributeError):
        return None


def load() -> str:
    """The 1-minute load average at the start and now ('' where unknown): other work on the
    machine slows every timing of the run."""
    if LOAD_AT_START is None:
        return ""
    return f"; load average {LOAD_AT_START:.1f} at the start, {os.getloadavg()[0]:.1f} at the end"


def machine() -> str:
    """One line: CPU, cores, memory, Python, NumPy and kalmanfield versions, the load."""
    memory = memory_gib()
    return (
        f"{cpu_name()}, {os.cpu_count()} logical cores"
        + (f", {memory:.0f} GiB" if memory else "")
        + f"; Python {platform.python_version()}, NumPy {np.__version__}, "
        f"kalmanfield {kf.__version__}{load()}"
    )


def shift_headings(body: str) -> str:
    """The report's Markdown headings moved so that its highest one is a level-2 heading (the
    page title is the only level-1 one)."""
    lines = body.split("\n")
    levels = [len(line) - len(line.lstrip("#")) for line in lines if line.startswith("#")]
    if not levels:
        return body
    shift = 2 - min(levels)
    return "\n".join(
        ("#" * (len(line) - len(line.lstrip("#")) + shift) + line.lstrip("#"))
        if line.startswith("#")
        else line
        for line in lines
    )


def write_page(name: str, title: str, body: str, *, full_run: bool) -> Path:
    """Write the report `body` (Markdown) as the page `name`, headed by `title`, today's date,
    the machine and the command line; a partial run (`full_run` False) goes to bench_out/.
    Returns the path written."""
    command = " ".join(["python", f"benches/{Path(sys.argv[0]).name}", *sys.argv[1:]])
    header = [
        f"# {title}",
        "",
        f"Run on {date.today().isoformat()} with `{command}`.",
        "",
        f"Machine: {machine()}. Timings on shared VMs vary by up to 2× between runs: compare "
        "rows of this page, not figures across pages or dates.",
        "",
    ]
    body = shift_headings(body)
    path = (PAGES if full_run else SCRATCH) / f"{name}.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(header) + "\n" + body.strip() + "\n", encoding="utf-8")
    print(f"(written to {path.relative_to(ROOT)})")
    return path
